// SPDX-License-Identifier: GPL-3.0-or-later
// The validate() of the continuum options: defaults pass, every number finite and in
// its documented range, the message naming quantity, range and value; the documented force bound.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "continuum/continuum_stretch.hpp"
#include "core/validation.hpp"

namespace {
using namespace rbc;
constexpr double inf = std::numeric_limits<double>::infinity();

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

TEST(Validate, ContinuumDefaultsAreValid) {
  EXPECT_NO_THROW(NewtonOptions{}.validate());
  EXPECT_NO_THROW(ContinuumOptions{}.validate());
  EXPECT_NO_THROW(ContinuumParameters{}.validate());
}

TEST(Validate, NewtonOptionsNameTheValue) {
  NewtonOptions n;
  n.max_iterations = -1;
  expect_invalid([&] { n.validate(); }, {"max iterations", "[1, 10000000]", "-1"});
  n = {};
  n.force_tolerance_pN = inf;
  expect_invalid([&] { n.validate(); }, {"force tolerance", "(0, 10] pN", "inf"});
  n = {};
  n.max_step_um = std::nan("");
  expect_invalid([&] { n.validate(); }, {"largest step", "nan"});
  ContinuumOptions c;
  c.max_bisections = -1;
  expect_invalid([&] { c.validate(); }, {"bisections", "-1"});
  c = {};
  c.lbfgs_area_stiffness = inf;
  expect_invalid([&] { c.validate(); }, {"area penalty stiffness", "inf"});
}

TEST(Validate, ContinuumForceBoundIsDocumentedAndChecked) {
  EXPECT_NO_THROW(validate_continuum_force(0.0));
  EXPECT_NO_THROW(validate_continuum_force(kMaxContinuumForce_pN));
  for (double bad : {-1.0, 401.0, 2000.0, 5000.0, inf})
    expect_invalid([&] { validate_continuum_force(bad); },
                   {"force (continuum model)", "[0, 400] pN"});
}

}  // namespace
