// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc stretch --mesh adapted` (continuum/adapted_mesh.hpp): the run is on the graded mesh the
// library builds (faces written to the shape file equal it, finer near the bead rims than in
// the middle), the same command gives the same mesh, another --mesh-seed another one, and the
// options are refused for the network, for the uniform mesh and out of range (exit 2).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_run.hpp"
#include "continuum/adapted_mesh.hpp"
#include "core/h5file.hpp"
#include "test_output.hpp"

namespace rbc {
namespace adapted_mesh_cli_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;
using testing::fresh_output_dir;
using testing::run_rbc;

std::string quoted(const fs::path& p) {
  std::string q = "'";
  q += p.string();
  q += '\'';
  return q;
}

TEST(AdaptedMeshCli, StretchRunsOnTheLibraryMeshAndRefusesMisuse) {
  const fs::path dir = fresh_output_dir("stretch_cli_adapted_mesh");
  const std::string base =
      "stretch --model continuum --mesh adapted --elements 600 --mesh-size-ratio 2.5 --force "
      "0,100 -q --json --no-picture --contact-load exact-contact";
  const CliRun r = run_rbc(base + " --out " + quoted(dir / "a"), 2);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const json run = json::parse(r.out);
  const json& p = run.at("points").at(1);
  EXPECT_TRUE(p.at("converged").get<bool>());

  AdaptedMeshOptions o;
  o.target_elements = 600;
  o.size_ratio = 2.5;
  const TriMesh mesh = make_adapted_mesh(o);
  EXPECT_EQ(p.at("elements").get<int>(), mesh.topo.num_faces());
  std::vector<int> faces;
  H5File::open_read((dir / "a" / "shape_0.0pN.h5").string()).read("/mesh/faces", faces);
  ASSERT_EQ(faces.size(), static_cast<std::size_t>(mesh.topo.faces.size()));
  for (std::size_t i = 0; i < faces.size(); ++i) ASSERT_EQ(faces[i], mesh.topo.faces.data()[i]);
  EXPECT_TRUE(fs::exists(dir / "a" / "shape_100.0pN.xdmf"));

  // Same command, same mesh and numbers; another seed, another mesh.
  const CliRun again = run_rbc(base, 1);
  ASSERT_EQ(again.exit_code, 0) << again.all();
  json first = run.at("points"), second = json::parse(again.out).at("points");
  for (json* points : {&first, &second})
    for (json& point : *points) point.erase("wall_s");
  EXPECT_EQ(first, second);
  const CliRun seeded = run_rbc(base + " --mesh-seed 5", 1);
  ASSERT_EQ(seeded.exit_code, 0) << seeded.all();
  EXPECT_NE(json::parse(seeded.out).at("points").at(1).at("axial_um"), p.at("axial_um"));

  for (const std::string& bad :
       {std::string("stretch --force 10 -q --mesh adapted"),
        std::string("stretch --model continuum --force 10 -q --mesh-size-ratio 2"),
        std::string("stretch --model continuum --force 10 -q --mesh-seed 2"),
        std::string("stretch --model continuum --force 10 -q --mesh adapted --mesh-orientation "
                    "mirror-planes"),
        std::string("stretch --model continuum --force 10 -q --mesh adapted --mesh-size-ratio 11"),
        std::string("stretch --model continuum --force 10 -q --mesh coarse")}) {
    const CliRun refused = run_rbc(bad);
    EXPECT_EQ(refused.exit_code, 2) << bad << "\n" << refused.all();
    EXPECT_EQ(refused.err.rfind("rbc: error: ", 0), 0u) << refused.all();
  }
}

}  // namespace
}  // namespace adapted_mesh_cli_test
}  // namespace rbc
