// SPDX-License-Identifier: GPL-3.0-or-later
// The validate() of every discrete options struct: defaults pass; every number must be
// finite and inside its documented range, and the message names the quantity, the range (in the
// user's units) and the value.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/validation.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/network.hpp"
#include "discrete/stretch.hpp"

namespace {
using namespace rbc;
constexpr double inf = std::numeric_limits<double>::infinity();
const double nan = std::nan("");

/// Expects f to throw an InvalidParameter whose message contains every fragment.
void expect_invalid(const std::function<void()>& f, const std::vector<std::string>& fragments) {
  try {
    f();
    ADD_FAILURE() << "no InvalidParameter thrown (expected: " << fragments.front() << ")";
  } catch (const InvalidParameter& e) {
    for (const auto& s : fragments)
      EXPECT_NE(std::string(e.what()).find(s), std::string::npos)
          << e.what() << " lacks '" << s << "'";
  }
}

TEST(Validate, DefaultsAreValid) {
  EXPECT_NO_THROW(NetworkParameters{}.validate());
  EXPECT_NO_THROW(StretchOptions{}.validate());
  EXPECT_NO_THROW(McOptions{}.validate());
  EXPECT_NO_THROW(McRunSetup{}.validate());
  EXPECT_NO_THROW(LbfgsOptions{}.validate());
}

TEST(Validate, WlcParametersAreFiniteAndPhysicalInNanometres) {
  for (double bad : {inf, nan, 0.0, -1.0, 20.0}) {  // 20 um = 20,000 nm > 10,000 nm
    WlcParameters p;
    p.persistence_um = bad;
    expect_invalid([&] { p.validate(); }, {"persistence length", "(0, 10000] nm"});
  }
  WlcParameters p;
  p.lmax_um = 0.06;  // below Lbar = 75 nm
  expect_invalid([&] { p.validate(); }, {"Lmax", "(75, 10000] nm", "got 60 nm"});
  p = {};
  p.lmax_um = inf;
  expect_invalid([&] { p.validate(); }, {"Lmax", "got inf"});
  p = {};
  p.temperature_K = inf;
  expect_invalid([&] { p.validate(); }, {"temperature", "(0, 1000] K", "got inf"});
  p = {};
  p.lbar_um = nan;
  expect_invalid([&] { p.validate(); }, {"Lbar", "got nan"});
}

TEST(Validate, StericBendingTweezersConstraints) {
  StericParameters s;
  s.eta = inf;
  expect_invalid([&] { s.validate(); }, {"eta", "(0, 1]", "inf"});
  s = {};
  s.q = 0;
  expect_invalid([&] { s.validate(); }, {"steric exponent q", "(0, 10]"});

  BendingParameters b;
  b.h0_per_um = 1e300;
  expect_invalid([&] { b.validate(); }, {"H0", "[-100, 100] 1/um", "1e+300"});
  b = {};
  b.h0_per_um = -100.0;  // the bound itself is allowed
  EXPECT_NO_THROW(b.validate());
  b.kappa_pNum = inf;
  expect_invalid([&] { b.validate(); }, {"kappa", "[0, 1e-16] J"});
  b = {};
  b.kappa_pNum = 0.0;  // bending off: allowed in the library (flat test patches)
  EXPECT_NO_THROW(b.validate());

  TweezersParameters t;
  t.contact_fraction = 0.5;
  expect_invalid([&] { t.validate(); }, {"contact fraction", "(0, 0.5)"});

  ConstraintParameters c;
  c.area_stiffness_pN_per_um3 = inf;
  expect_invalid([&] { c.validate(); }, {"area penalty stiffness", "inf"});
  c = {};
  c.tolerance = 1.0;
  expect_invalid([&] { c.validate(); }, {"tolerance", "(0, 1)"});
}

TEST(Validate, StretchOptionsBudgetAndTolerance) {
  StretchOptions o;
  o.minimiser.force_tolerance = inf;
  expect_invalid([&] { o.validate(); }, {"force tolerance", "(0, 10] pN", "inf"});
  o = {};
  o.minimiser.max_iterations = -5;
  expect_invalid([&] { o.validate(); }, {"max iterations", "[1, 10000000]", "-5"});
  o = {};
  o.max_outer_iterations = 0;
  expect_invalid([&] { o.validate(); }, {"augmented-Lagrangian updates"});
}

TEST(Validate, DiscreteForceBoundIsDocumentedAndChecked) {
  EXPECT_NO_THROW(validate_discrete_force(0.0));
  EXPECT_NO_THROW(validate_discrete_force(kMaxDiscreteForce_pN));
  for (double bad : {-1.0, std::nextafter(kMaxDiscreteForce_pN, inf), 1e6, 1e308, inf, nan})
    expect_invalid([&] { validate_discrete_force(bad); },
                   {"force (discrete model)", "[0, 500] pN"});
}

TEST(Validate, MonteCarloOptions) {
  McOptions m;
  m.temperature_K = inf;
  expect_invalid([&] { m.validate(); }, {"sampling temperature", "[0, 100000] K"});
  m = {};
  m.streams = 0;
  expect_invalid([&] { m.validate(); }, {"RNG streams", "[1, 1024]", "got 0"});
  m = {};
  m.target_acceptance = nan;
  expect_invalid([&] { m.validate(); }, {"target acceptance"});

  McRunSetup s;
  s.force_pN = 1e6;  // the start is the T = 0 equilibrium: the discrete bound applies
  expect_invalid([&] { s.validate(); }, {"force (discrete model)", "1e+06"});
  s = {};
  s.penalty_scale = inf;
  expect_invalid([&] { s.validate(); }, {"penalty scale", "inf"});
  s = {};
  s.sample_every = 0;
  expect_invalid([&] { s.validate(); }, {"sample interval"});
}

}  // namespace
