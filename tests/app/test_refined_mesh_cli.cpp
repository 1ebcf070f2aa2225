// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc stretch --mesh refined` (continuum/refined_mesh.hpp): the run is on the mesh the library
// builds (same element count), --symmetry mirror reduces it by the icosphere's mirrors and finds
// the full solve's diameters, and the options are refused for the network, the uniform mesh and
// out of range (exit 2); --mesh-volume is refused off the refined mesh.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "cli_run.hpp"
#include "continuum/refined_mesh.hpp"

namespace rbc {
namespace refined_mesh_cli_test {
namespace {

using nlohmann::json;
using testing::CliRun;
using testing::run_rbc;

TEST(RefinedMeshCli, StretchRunsOnTheLibraryMeshWithItsMirrorsAndRefusesMisuse) {
  const std::string base =
      "stretch --model continuum --order full --mesh refined --elements 1700 --mesh-size-ratio 3 "
      "--force 0,60 -q --json --contact-load exact-contact --measure quadric-fit";
  const CliRun full = run_rbc(base, 1);
  ASSERT_EQ(full.exit_code, 0) << full.all();
  const CliRun mirror = run_rbc(base + " --symmetry mirror", 1);
  ASSERT_EQ(mirror.exit_code, 0) << mirror.all();
  RefinedMeshOptions o;
  o.target_elements = 1700;
  o.size_ratio = 3;
  RefinedMeshReport rep;
  make_refined_mesh(o, &rep);
  const json a = json::parse(full.out).at("points"), b = json::parse(mirror.out).at("points");
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(a[k].at("elements").get<int>(), rep.elements);
    EXPECT_TRUE(a[k].at("converged").get<bool>());
    EXPECT_TRUE(b[k].at("converged").get<bool>());
    EXPECT_FALSE(a[k].contains("symmetry_order"));       // reported by the mirror path only
    EXPECT_EQ(b[k].at("symmetry_order").get<int>(), 4);  // the icosphere's four mirrors
    for (const char* d : {"axial_um", "transverse_um"})
      EXPECT_NEAR(a[k].at(d).get<double>(), b[k].at(d).get<double>(), 1e-6) << d;
  }
  EXPECT_GT(a[1].at("axial_um").get<double>(), a[0].at("axial_um").get<double>() + 1.0);

  // --mesh-volume scale: the same mesh scaled by s about the centre. The in-plane reference is
  // the rest mesh and the constraints keep each mesh's own rest area and volume, so at 0 pN the
  // scaled cell is the other one times s, and so are its quadric-fit diameters, but for the
  // relaxation of the rest shape under bending: bending (H0 = 0) is scale-free while the
  // in-plane energy grows with the area, so its weight changes by s^-2 (measured: the ratio
  // differs from s by 1.3e-5, against s - 1 = 1.1e-3).
  const CliRun scaled = run_rbc(base + " --mesh-volume scale", 1);
  ASSERT_EQ(scaled.exit_code, 0) << scaled.all();
  o.match_volume = true;
  RefinedMeshReport scaled_rep;
  make_refined_mesh(o, &scaled_rep);
  ASSERT_GT(scaled_rep.volume_scale, 1.0005);
  const json c = json::parse(scaled.out).at("points");
  for (const char* d : {"axial_um", "transverse_um"})
    EXPECT_NEAR(c[0].at(d).get<double>() / a[0].at(d).get<double>(), scaled_rep.volume_scale, 1e-4)
        << d;

  for (const std::string& bad :
       {std::string("stretch --force 10 -q --mesh refined"),
        std::string("stretch --model continuum --force 10 -q --mesh refined --mesh-size-ratio 11"),
        std::string("stretch --model continuum --force 10 -q --mesh refined --mesh-size-ratio 0.5"),
        std::string("stretch --model continuum --force 10 -q --mesh-seed 2"),
        std::string("stretch --model continuum --force 10 -q --mesh-volume sagitta"),
        std::string("stretch --model continuum --force 10 -q --mesh refined --mesh-volume 1")}) {
    const CliRun refused = run_rbc(bad);
    EXPECT_EQ(refused.exit_code, 2) << bad << "\n" << refused.all();
    EXPECT_EQ(refused.err.rfind("rbc: error: ", 0), 0u) << refused.all();
  }
}

}  // namespace
}  // namespace refined_mesh_cli_test
}  // namespace rbc
