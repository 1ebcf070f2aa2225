// SPDX-License-Identifier: GPL-3.0-or-later
// Validation of the homogenisation inputs: the user's membrane parameters (nm, K) and
// the disordered-network options, every number finite and in its documented range.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/validation.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/membrane_inputs.hpp"

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

TEST(Validate, MembraneInputsInTheUsersUnits) {
  EXPECT_NO_THROW(MembraneInputs{}.wlc());
  EXPECT_NO_THROW(MembraneInputs{}.steric());
  MembraneInputs m;
  m.temperature_K = inf;
  expect_invalid([&] { m.wlc(); }, {"temperature", "(0, 1000] K", "inf"});
  m = {};
  m.lmax_nm = inf;
  expect_invalid([&] { m.wlc(); }, {"Lmax", "(75, 10000] nm", "inf"});
  m = {};
  m.persistence_nm = 0;
  expect_invalid([&] { m.wlc(); }, {"persistence length", "got 0 nm"});
  m = {};
  m.eta = inf;
  expect_invalid([&] { m.steric(); }, {"eta", "inf"});
}

TEST(Validate, DisorderOptionsNameTheValue) {
  EXPECT_NO_THROW(DisorderOptions{}.validate());
  DisorderOptions d;
  d.cells = 3;
  expect_invalid([&] { d.validate(); }, {"cells", "[4, 200]", "3"});
  d = {};
  d.disorder = std::nan("");
  expect_invalid([&] { d.validate(); }, {"disorder X", "[0, 1]", "nan"});
  d = {};
  d.spacing_um = inf;
  expect_invalid([&] { d.validate(); }, {"spacing", "inf"});
}

}  // namespace
