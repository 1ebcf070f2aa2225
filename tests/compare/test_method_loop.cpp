// SPDX-License-Identifier: GPL-3.0-or-later
// The Loop element as a method of the comparison (compare/methods.hpp Method::loop): its name and
// spec round-trip, run_method runs the library's sweep on both solver paths, and the accuracy
// study writes its rows beside the table, where the --accuracy choice reads them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "compare/accuracy_choice.hpp"
#include "compare/accuracy_study.hpp"
#include "compare/methods.hpp"
#include "continuum/adapted_mesh.hpp"
#include "continuum/loop_stretch.hpp"
#include "core/io.hpp"
#include "homogenise/invariant_laws.hpp"
#include "test_output.hpp"
#include "tiny_study.hpp"

namespace rbc {
namespace method_loop_test {
namespace {

TEST(MethodLoop, ParsesNamesAndWritesBack) {
  const Method m = parse_method("continuum-loop:full:980");
  EXPECT_EQ(m.kind, MethodKind::continuum);
  EXPECT_TRUE(m.loop);
  EXPECT_FALSE(m.adapted || m.refined);
  EXPECT_EQ(m.order, WlcExpansion::full);
  EXPECT_EQ(m.resolution, 980);
  EXPECT_EQ(m.name(), "continuum_loop_pfull_E980");
  EXPECT_EQ(method_spec(m), "continuum-loop:full:980");
  Method r = parse_method("continuum-loop:2:2000");
  r.rotation_seed = 3;
  EXPECT_EQ(r.name(), "continuum_loop_p2_E2000_r3");
  EXPECT_TRUE(parse_method(method_spec(r)).loop);
  EXPECT_NE(parse_method("continuum:full:980").name(), m.name());
  for (const std::string bad : {"continuum-loop:full:100", "continuum-loop:full:980:2",
                                "continuum-loop:7:980", "continuum-loop:full"})
    EXPECT_THROW(parse_method(bad), std::invalid_argument) << bad;
}

TEST(MethodLoop, RunsTheLibrarysSweepOnBothPaths) {
  const Method m = parse_method("continuum-loop:full:500");
  const std::vector<double> forces{0.0, 80.0};
  RunMethodOptions full, mirror;
  mirror.symmetry = Symmetry::mirror;
  const MethodRun a = run_method(m, forces, {}, full), b = run_method(m, forces, {}, mirror);
  ASSERT_TRUE(a.all_converged() && b.all_converged());
  // The library's sweep on the same control mesh.
  const EvansFungShape shape;
  TriMesh mesh = make_continuum_mesh(500, shape);
  for (int i = 0; i < mesh.x.cols(); ++i) mesh.x.col(i) = evans_fung_project(shape, mesh.x.col(i));
  const NetworkParameters p;
  const LoopContinuumModel model =
      build_loop_continuum_model(mesh, make_membrane_law(p.wlc, p.steric, WlcExpansion::full),
                                 p.bending, rest_contact_plane(shape, p.tweezers.contact_fraction));
  const auto direct = run_loop_stretch(model, forces);
  EXPECT_EQ(a.elements, 500);
  EXPECT_EQ(a.vertices, 252);
  EXPECT_NEAR(a.patch_plus_um2, 0.05 * a.surface_um2, 0.01 * a.surface_um2);
  for (std::size_t k = 0; k < forces.size(); ++k) {
    EXPECT_EQ(a.points[k].axial_um, direct[k].diameters.axial_um);
    EXPECT_EQ(a.points[k].transverse_um, direct[k].diameters.transverse_um);
  }
  // Under load the two paths agree (at 0 pN the turns about y and z are free and they end up a
  // turn of about 1e-4 rad apart, at the same energy).
  EXPECT_NEAR(b.points[1].axial_um, a.points[1].axial_um, 1e-6);
  EXPECT_NEAR(b.points[1].transverse_um, a.points[1].transverse_um, 1e-6);
  EXPECT_GT(a.points[1].axial_um, a.points[0].axial_um + 1.0);
}

TEST(MethodLoop, StudyRowsBesideTheTableAreWhatTheChoiceReads) {
  const std::filesystem::path dir = rbc::testing::fresh_output_dir("MethodLoop_StudyRows");
  AccuracyStudyOptions o = testing::tiny_study_options();
  o.loop_elements = {500};
  const AccuracyStudy st = run_accuracy_study(o, {});
  // The Loop sweeps: the default orientation on both paths, the rotation in full.
  const testing::KindSweeps k = testing::kind_sweeps(st, [](const Method& m) { return m.loop; });
  ASSERT_EQ(k.full.size(), 2u);
  EXPECT_EQ(k.mirror, 1);
  const std::vector<double>& worst = k.worst;
  write_accuracy_study(st, dir.string());
  for (const char* f : {"accuracy_cost_loop.csv", "accuracy_by_force_loop.csv",
                        "convergence_loop.csv", "orders_loop.csv"})
    EXPECT_TRUE(std::filesystem::exists(dir / f)) << f;
  const AccuracyCostTable cost =
      load_accuracy_cost((dir / "accuracy_cost_loop.csv").string(), CostRows::loop);
  ASSERT_EQ(cost.rows.size(), 2u);  // the full and the mirror path
  for (const AccuracyRow& r : cost.rows) {
    EXPECT_TRUE(r.method.loop);
    EXPECT_EQ(r.rotations, 2);
    EXPECT_NEAR(r.error_all, *std::max_element(worst.begin(), worst.end()), 1e-9);
  }
  // The --accuracy table: the network's rows and the Loop rows, per force.
  const AccuracyTable table =
      load_accuracy_table_with_adapted((dir / "accuracy_by_force.csv").string());
  int loop_entries = 0;
  for (const AccuracyEntry& e : table.entries)
    if (e.method.loop) {
      ++loop_entries;
      EXPECT_EQ(method_spec(e.method), "continuum-loop:full:500");
      ASSERT_EQ(e.error.size(), worst.size());
      for (size_t f = 0; f < worst.size(); ++f) EXPECT_NEAR(e.error[f], worst[f], 1e-9);
    }
  EXPECT_EQ(loop_entries, 2);
}

}  // namespace
}  // namespace method_loop_test
}  // namespace rbc
