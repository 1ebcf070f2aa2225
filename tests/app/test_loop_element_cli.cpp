// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc stretch --element loop` (continuum/loop_stretch.hpp): the run is the library's sweep,
// --symmetry mirror reduces it by the icosphere's four mirrors and finds the full solve's
// diameters (under load: at 0 pN the turns about y and z are free too and the two paths end up a
// turn of 1e-4 rad apart, at the same energy), --out writes the limit surface's shapes with the
// run's record, and the options that choose another load, measure or mesh are refused with it (exit
// 2, before any work).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_run.hpp"
#include "test_output.hpp"

namespace rbc {
namespace loop_element_cli_test {
namespace {

using nlohmann::json;
using testing::CliRun;
using testing::run_rbc;

TEST(LoopElementCli, StretchRunsOnBothPathsWritesItsShapesAndRefusesMisuse) {
  const std::string base =
      "stretch --model continuum --element loop --order full --elements 500 --force 10,60 -q "
      "--json";
  const CliRun full = run_rbc(base, 1);
  ASSERT_EQ(full.exit_code, 0) << full.all();
  const std::filesystem::path out = rbc::testing::fresh_output_dir("loop_element_cli") / "o";
  const CliRun mirror = run_rbc(base + " --symmetry mirror --out '" + out.string() + "'", 1);
  ASSERT_EQ(mirror.exit_code, 0) << mirror.all();
  const json a = json::parse(full.out).at("points"), b = json::parse(mirror.out).at("points");
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(a[k].at("elements").get<int>(), 500);
    EXPECT_EQ(a[k].at("vertices").get<int>(), 252);
    EXPECT_TRUE(a[k].at("converged").get<bool>());
    EXPECT_TRUE(b[k].at("converged").get<bool>());
    EXPECT_EQ(b[k].at("symmetry_order").get<int>(), 4);
    for (const char* d : {"axial_um", "transverse_um"})
      EXPECT_NEAR(a[k].at(d).get<double>(), b[k].at(d).get<double>(), 1e-6) << d;
  }
  EXPECT_GT(a[1].at("axial_um").get<double>(), a[0].at("axial_um").get<double>() + 1.0);
  // The shapes and the record of what produced them.
  EXPECT_TRUE(std::filesystem::exists(out / "stretch.csv"));
  EXPECT_TRUE(std::filesystem::exists(out / "shape_60.0pN.h5"));
  EXPECT_TRUE(std::filesystem::exists(out / "shape_60.0pN.xdmf"));
  std::ifstream manifest(out / "run.json");
  const json run = json::parse(manifest);
  EXPECT_EQ(run.at("element").get<std::string>(), "loop");
  EXPECT_TRUE(run.at("complete").get<bool>());
  EXPECT_EQ(run.at("config").at("element").get<std::string>(), "loop");

  const std::string loop = "stretch --model continuum --element loop --force 10 -q ";
  for (const std::string& bad :
       {loop + "--mesh refined", loop + "--mesh-size-ratio 2", loop + "--mesh-seed 1",
        loop + "--contact-load exact-contact", loop + "--measure quadric-fit",
        loop + "--symmetry mirror --symmetry-check highest-force", loop + "--warm-start somewhere",
        std::string("stretch --force 10 -q --element loop"),
        std::string("stretch --model continuum --force 10 -q --element quadratic"),
        std::string("stretch --force 10 -q --accuracy 1% --element loop")}) {
    const CliRun refused = run_rbc(bad);
    EXPECT_EQ(refused.exit_code, 2) << bad << "\n" << refused.all();
    EXPECT_EQ(refused.err.rfind("rbc: error: ", 0), 0u) << refused.all();
    EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.all();
  }
}

}  // namespace
}  // namespace loop_element_cli_test
}  // namespace rbc
