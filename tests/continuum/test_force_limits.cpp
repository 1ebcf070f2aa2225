// SPDX-License-Identifier: GPL-3.0-or-later
// The continuum model's documented force maximum (kMaxContinuumForce_pN) is held by the
// library: ContinuumOptions::validate(forces) refuses a force beyond it, NaN and inf, and every
// entry point that solves (run_continuum_stretch, ContinuumSweepSolver, a dynamics step) runs
// that check before any work. A study of the range beyond opts in explicitly.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "continuum/continuum_stretch.hpp"
#include "continuum/dynamics.hpp"
#include "core/validation.hpp"
#include "invalid_parameter.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const double kNaN = std::nan("");

using testing::limit_refusal;

TEST(ForceLimits, ContinuumOptionsValidateHoldsTheContinuumMaximum) {
  const ContinuumOptions o;
  EXPECT_NO_THROW(o.validate({0.0, 193.0, kMaxContinuumForce_pN}));
  EXPECT_EQ(limit_refusal([&] {
              o.validate({0.0, 1000.0});
            }),
            "force (continuum model) must be finite and in [0, 400] pN, got 1000 pN");
  for (double bad : {kNaN, kInf, -kInf, -1.0, 400.5})
    EXPECT_NE(limit_refusal([&] { o.validate({bad}); }).find("force (continuum model)"),
              std::string::npos);
  ContinuumOptions beyond;
  beyond.beyond_documented_force_range = true;
  EXPECT_NO_THROW(beyond.validate({500.0, 5000.0}));
  EXPECT_EQ(limit_refusal([&] { beyond.validate({kInf}); }),
            "force (continuum model) must be finite and >= 0 pN, got inf");
}

TEST(ForceLimits, EverySolvingEntryPointRefusesBeforeAnyWork) {
  const TriMesh mesh = make_continuum_mesh(200);
  const ContinuumModel model =
      build_continuum_model(mesh, testing::closed_form_p2_law(WlcParameters{}), {});
  int messages = 0;
  const ProgressSink count = [&](const std::string&) { ++messages; };
  ContinuumOptions o;
  // The first force is valid: a check made force by force would have solved it.
  EXPECT_NE(limit_refusal([&] {
              run_continuum_stretch(model, {0.0, 1000.0}, o, count);
            }).find("got 1000 pN"),
            std::string::npos);
  ContinuumSweepSolver sweep(o);
  EXPECT_NE(limit_refusal([&] {
              sweep.run(model, {0.0, kNaN}, count);
            }).find("got nan"),
            std::string::npos);
  EXPECT_EQ(messages, 0);

  ContinuumDynamics dynamics(model, ContinuumDynamicsOptions{});
  DynamicsState s{model.rest, {}};
  EXPECT_NE(limit_refusal([&] { dynamics.step(1000.0, 1e-3, s); }).find("[0, 400] pN"),
            std::string::npos);
  EXPECT_EQ(s.x, model.rest);
}

}  // namespace
}  // namespace rbc
