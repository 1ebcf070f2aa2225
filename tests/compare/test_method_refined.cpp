// SPDX-License-Identifier: GPL-3.0-or-later
// The refined-mesh Method spec "continuum-refined:ORDER:ELEMENTS[:RATIO]": parsed to the refined
// continuum method with its size ratio, named apart from the uniform and adapted methods (the
// cache files differ), written back by method_spec; run on the library's refined mesh on both
// solver paths (same diameters), another mesh when turned; and the accuracy study's refined rows,
// written beside the table, follow from their sweeps (errors worst over the default orientation and
// its rotation).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "compare/accuracy_choice.hpp"
#include "compare/accuracy_study.hpp"
#include "compare/methods.hpp"
#include "continuum/refined_mesh.hpp"
#include "core/io.hpp"
#include "test_output.hpp"
#include "tiny_study.hpp"

namespace rbc {
namespace method_refined_test {
namespace {

TEST(MethodRefined, ParsesNamesAndWritesBack) {
  const Method m = parse_method("continuum-refined:full:1700:3");
  EXPECT_EQ(m.kind, MethodKind::continuum);
  EXPECT_TRUE(m.refined);
  EXPECT_FALSE(m.adapted);
  EXPECT_EQ(m.order, WlcExpansion::full);
  EXPECT_EQ(m.resolution, 1700);
  EXPECT_EQ(m.size_ratio, 3.0);
  EXPECT_EQ(m.name(), "continuum_refined3_pfull_E1700");
  EXPECT_EQ(method_spec(m), "continuum-refined:full:1700:3");
  Method r = parse_method("continuum-refined:2:2400");
  EXPECT_EQ(r.size_ratio, 2.0);
  r.rotation_seed = 2;
  EXPECT_EQ(r.name(), "continuum_refined2_p2_E2400_r2");
  EXPECT_TRUE(parse_method(method_spec(r)).refined);
  EXPECT_NE(parse_method("continuum-adapted:full:1700:3").name(), m.name());
  for (const std::string bad : {"continuum-refined:full:100", "continuum-refined:full:2000:11",
                                "continuum-refined:5:2000", "continuum-refined:full"})
    EXPECT_THROW(parse_method(bad), std::invalid_argument) << bad;
}

TEST(MethodRefined, RunsOnTheRefinedMeshOnBothSolverPaths) {
  const Method m = parse_method("continuum-refined:full:1700:3");
  RefinedMeshOptions o;
  o.target_elements = 1700;
  o.size_ratio = 3;
  RefinedMeshReport rep;
  make_refined_mesh(o, &rep);
  const std::vector<double> forces = {0.0, 60.0};
  RunMethodOptions full, mirror;
  mirror.symmetry = Symmetry::mirror;
  const MethodRun a = run_method(m, forces, {}, full);
  const MethodRun b = run_method(m, forces, {}, mirror);
  EXPECT_EQ(a.elements, rep.elements);
  EXPECT_EQ(b.elements, rep.elements);
  ASSERT_TRUE(a.all_converged() && b.all_converged());
  for (size_t k = 0; k < forces.size(); ++k) {
    EXPECT_NEAR(a.points[k].axial_um, b.points[k].axial_um, 1e-6);
    EXPECT_NEAR(a.points[k].transverse_um, b.points[k].transverse_um, 1e-6);
  }
  Method turned = m;
  turned.rotation_seed = 1;
  const MethodRun c = run_method(turned, forces, {}, full);
  EXPECT_NE(c.points[1].axial_um, a.points[1].axial_um);
}

TEST(MethodRefined, StudyRowsBesideTheTableFollowFromTheirSweeps) {
  const std::filesystem::path dir = rbc::testing::fresh_output_dir("MethodRefined_StudyRows");
  AccuracyStudyOptions o = testing::tiny_study_options();
  o.refined_elements = {1700};
  o.refined_size_ratios = {3.0};
  const AccuracyStudy st = run_accuracy_study(o, {});
  // The refined sweeps: the default orientation on both paths, the rotation in full.
  const testing::KindSweeps k = testing::kind_sweeps(st, [](const Method& m) { return m.refined; });
  ASSERT_EQ(k.full.size(), 2u);
  EXPECT_EQ(k.mirror, 1);
  const double worst = *std::max_element(k.worst.begin(), k.worst.end());
  write_accuracy_study(st, dir.string());
  ASSERT_TRUE(std::filesystem::exists(dir / "accuracy_cost_refined.csv"));
  ASSERT_TRUE(std::filesystem::exists(dir / "accuracy_by_force_refined.csv"));
  ASSERT_TRUE(std::filesystem::exists(dir / "convergence_refined.csv"));
  const CsvTable t = read_csv((dir / "accuracy_cost_refined.csv").string());
  const auto col = [&](const std::string& name) {
    return static_cast<size_t>(std::find(t.header.begin(), t.header.end(), name) -
                               t.header.begin());
  };
  ASSERT_EQ(t.rows.size(), 2u);  // the full and the mirror path
  for (const auto& row : t.rows) {
    EXPECT_EQ(row[col("rotations")], 2);
    EXPECT_EQ(row[col("size_ratio")], 3);
    EXPECT_NEAR(row[col("error_all")], worst, 1e-6 * worst);
  }
  // The table's own file keeps no refined row.
  const CsvTable main = read_csv((dir / "accuracy_cost.csv").string());
  const size_t resolution = static_cast<size_t>(
      std::find(main.header.begin(), main.header.end(), "resolution") - main.header.begin());
  ASSERT_LT(resolution, main.header.size());
  for (const auto& row : main.rows) EXPECT_EQ(row[resolution], 300);  // the reference size's
}

}  // namespace
}  // namespace method_refined_test
}  // namespace rbc
