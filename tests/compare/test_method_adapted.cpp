// SPDX-License-Identifier: GPL-3.0-or-later
// The adapted-mesh Method spec "continuum-adapted:ORDER:ELEMENTS[:RATIO]": parsed to the adapted
// continuum method with its size ratio, named apart from the uniform mesh's method of the same
// size (the cache files differ), written back by method_spec to the same method, and refused
// with a message naming the text outside its ranges.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "compare/accuracy_choice.hpp"
#include "compare/methods.hpp"

namespace rbc {
namespace method_adapted_test {
namespace {

TEST(MethodAdapted, ParsesNamesAndWritesBack) {
  const Method m = parse_method("continuum-adapted:full:2000");
  EXPECT_EQ(m.kind, MethodKind::continuum);
  EXPECT_TRUE(m.adapted);
  EXPECT_EQ(m.order, WlcExpansion::full);
  EXPECT_EQ(m.resolution, 2000);
  EXPECT_EQ(m.size_ratio, 2.0);
  EXPECT_EQ(m.name(), "continuum_adapted2_pfull_E2000");
  EXPECT_EQ(method_spec(m), "continuum-adapted:full:2000:2");

  Method r = parse_method("continuum-adapted:2:500:2.5");
  EXPECT_EQ(r.order, WlcExpansion::order2);
  EXPECT_EQ(r.size_ratio, 2.5);
  r.rotation_seed = 3;
  EXPECT_EQ(r.name(), "continuum_adapted2.5_p2_E500_r3");
  const Method back = parse_method(method_spec(r));
  EXPECT_TRUE(back.adapted);
  EXPECT_EQ(back.size_ratio, 2.5);
  EXPECT_EQ(back.resolution, 500);

  // The uniform mesh's method keeps its name and spec.
  const Method u = parse_method("continuum:full:2000");
  EXPECT_FALSE(u.adapted);
  EXPECT_EQ(u.name(), "continuum_pfull_E2000");
  EXPECT_EQ(method_spec(u), "continuum:full:2000");
}

TEST(MethodAdapted, RefusesValuesOutOfRange) {
  for (const std::string bad :
       {"continuum-adapted:full:100", "continuum-adapted:full:90000", "continuum-adapted:5:2000",
        "continuum-adapted:full:2000:0.5", "continuum-adapted:full:2000:11",
        "continuum-adapted:full:2000:nan", "continuum-adapted:full:2000:2x",
        "continuum-adapted:full", "continuum-adapted:full:2000:2:1"}) {
    try {
      parse_method(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(bad.substr(0, 17)), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace method_adapted_test
}  // namespace rbc
