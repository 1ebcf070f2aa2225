// SPDX-License-Identifier: GPL-3.0-or-later
// The adapted-mesh Method spec "continuum-adapted:ORDER:ELEMENTS[:RATIO]": parsed to the adapted
// continuum method with its size ratio, named apart from the uniform mesh's method of the same
// size (the cache files differ), written back by method_spec to the same method, and refused
// with a message naming the text outside its ranges.
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>
#include <string>

#include "compare/accuracy_choice.hpp"
#include "compare/methods.hpp"
#include "core/io.hpp"
#include "test_output.hpp"

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

// accuracy_by_force_adapted.csv beside the table: its rows become adapted entries with their size
// ratio, a choice can fall on them, and a file of another table (another reference_se) is
// refused; without it the table is read alone.
TEST(MethodAdapted, TableWithAdaptedRowsLoadsAndChooses) {
  const std::filesystem::path dir = testing::fresh_output_dir("MethodAdapted_TableWithAdapted");
  CsvTable t;
  t.header = {"kind",     "order", "resolution",   "converged", "cost_eg",
              "force_pN", "error", "reference_se", "symmetry"};
  t.rows = {{0, 0, 1000, 1, 2000, 0, 0.004, 0.0005, 1},
            {0, 0, 1000, 1, 2000, 100, 0.006, 0.0005, 1},
            {1, 0, 2000, 1, 3000, 0, 0.003, 0.0005, 0},
            {1, 0, 2000, 1, 3000, 100, 0.005, 0.0005, 0}};
  const std::string path = (dir / "accuracy_by_force.csv").string();
  write_csv(path, t);
  EXPECT_EQ(load_accuracy_table_with_adapted(path).entries.size(), 2u);

  CsvTable a = t;
  a.header.push_back("size_ratio");
  a.rows = {{1, 0, 1000, 1, 1500, 0, 0.002, 0.0005, 0, 3},
            {1, 0, 1000, 1, 1500, 100, 0.004, 0.0005, 0, 3}};
  write_csv((dir / "accuracy_by_force_adapted.csv").string(), a);
  const AccuracyTable both = load_accuracy_table_with_adapted(path);
  ASSERT_EQ(both.entries.size(), 3u);
  const Method& m = both.entries[2].method;
  EXPECT_TRUE(m.adapted);
  EXPECT_EQ(m.size_ratio, 3.0);
  EXPECT_EQ(m.resolution, 1000);
  EXPECT_EQ(both.reference_relative_se, 0.0005);
  // 0.5 %: the adapted row (error 0.4 % + 0.05 %) is the cheapest that qualifies.
  const AccuracyChoice ch = choose_by_accuracy(both, {100}, 0.5);
  EXPECT_EQ(method_spec(ch.chosen.method), "continuum-adapted:full:1000:3");
  // load_accuracy_table reads the table alone.
  EXPECT_EQ(load_accuracy_table(path).entries.size(), 2u);

  for (auto& q : a.rows) q[7] = 0.001;  // another table's reference
  write_csv((dir / "accuracy_by_force_adapted.csv").string(), a);
  EXPECT_THROW(load_accuracy_table_with_adapted(path), std::runtime_error);
  a.rows[0][7] = a.rows[1][7] = 0.0005;
  a.rows[0][9] = a.rows[1][9] = 12;  // size ratio out of range
  write_csv((dir / "accuracy_by_force_adapted.csv").string(), a);
  EXPECT_THROW(load_accuracy_table_with_adapted(path), std::runtime_error);
}

}  // namespace
}  // namespace method_adapted_test
}  // namespace rbc
