// SPDX-License-Identifier: GPL-3.0-or-later
// The discrete model's documented force maximum (kMaxDiscreteForce_pN) is held by the library,
// not by a front end: StretchOptions::validate(forces) refuses a force beyond it, NaN and inf,
// and every entry point that solves (run_stretch, StretchSweepSolver, solve_equilibrium, a
// dynamics step) runs that check before any work. A study of the range beyond opts in
// explicitly (beyond_documented_force_range).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/rest_shape.hpp"
#include "core/validation.hpp"
#include "discrete/dynamics.hpp"
#include "discrete/stretch.hpp"
#include "invalid_parameter.hpp"

namespace rbc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const double kNaN = std::nan("");

using testing::limit_refusal;

const Network& limits_network() {
  static const Network net = [] {
    RestShapeOptions o;
    o.target_vertices = 100;
    return build_network(make_rest_shape(o), NetworkParameters{});
  }();
  return net;
}

TEST(ForceLimits, StretchOptionsValidateHoldsTheDiscreteMaximum) {
  const StretchOptions o;
  EXPECT_NO_THROW(o.validate({0.0, 16.0, kMaxDiscreteForce_pN}));
  EXPECT_EQ(limit_refusal([&] {
              o.validate({0.0, 800.0});
            }),
            "force (discrete model) must be finite and in [0, 500] pN, got 800 pN");
  EXPECT_NE(limit_refusal([&] { o.validate({std::nextafter(kMaxDiscreteForce_pN, kInf)}); }), "");
  for (double bad : {kNaN, kInf, -kInf, -1.0, 1e6})
    EXPECT_NE(limit_refusal([&] {
                o.validate({0.0, bad});
              }).find("force (discrete model)"),
              std::string::npos);
  // The options themselves are checked too (the forces' overload includes validate()).
  StretchOptions bad_options;
  bad_options.minimiser.force_tolerance = kNaN;
  EXPECT_NE(limit_refusal([&] { bad_options.validate({0.0}); }).find("force tolerance"),
            std::string::npos);
}

TEST(ForceLimits, BeyondTheDocumentedRangeIsAnExplicitChoiceAndStillFinite) {
  StretchOptions o;
  o.beyond_documented_force_range = true;
  EXPECT_NO_THROW(o.validate({0.0, 800.0, 5000.0}));
  EXPECT_EQ(limit_refusal([&] { o.validate({kNaN}); }),
            "force (discrete model) must be finite and >= 0 pN, got nan");
  EXPECT_NE(limit_refusal([&] { o.validate({-1.0}); }), "");
  EXPECT_NE(limit_refusal([&] { o.validate({kInf}); }), "");
}

TEST(ForceLimits, EverySolvingEntryPointRefusesBeforeAnyWork) {
  const Network& net = limits_network();
  int points = 0, messages = 0;
  StretchOptions o;
  o.on_point = [&](const StretchPoint&) { ++points; };
  const ProgressSink count = [&](const std::string&) { ++messages; };
  // The first force is valid: a check made force by force would have solved it.
  EXPECT_NE(limit_refusal([&] {
              run_stretch(net, {0.0, 800.0}, o, count);
            }).find("got 800 pN"),
            std::string::npos);
  StretchSweepSolver sweep(o);
  EXPECT_NE(limit_refusal([&] {
              sweep.run(net, {0.0, 1e6}, count);
            }).find("got 1e+06 pN"),
            std::string::npos);
  EXPECT_EQ(points, 0);
  EXPECT_EQ(messages, 0);

  Positions x = net.rest;
  ConstraintMultipliers lambda;
  EXPECT_NE(limit_refusal([&] { solve_equilibrium(net, 800.0, x, lambda, o); }).find("[0, 500] pN"),
            std::string::npos);
  EXPECT_NE(limit_refusal([&] { solve_equilibrium(net, kNaN, x, lambda, o); }).find("nan"),
            std::string::npos);
  EXPECT_EQ(x, net.rest);  // untouched

  DynamicsState s{net.rest, {}};
  EXPECT_NE(
      limit_refusal([&] { discrete_dynamics_step(net, 800.0, 1e-3, s, {}); }).find("got 800 pN"),
      std::string::npos);
  EXPECT_EQ(s.x, net.rest);
}

TEST(ForceLimits, TheMaximumItselfIsSolved) {
  StretchOptions o;
  const auto pts = run_stretch(limits_network(), {kMaxDiscreteForce_pN}, o);
  ASSERT_EQ(pts.size(), 1u);
  EXPECT_TRUE(pts[0].converged) << to_string(pts[0].status);
  EXPECT_GT(pts[0].axial_um, 2 * 7.8);  // stretched well past the rest diameter
}

}  // namespace
}  // namespace rbc
