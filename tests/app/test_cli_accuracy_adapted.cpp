// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc tradeoff --accuracy-table` with adapted-mesh rows (--adapted-elements): each row's sweeps
// are the runs of `rbc stretch --mesh adapted --contact-load exact-contact --measure
// quadric-fit` on the mesh seeds 0 .. K-1 (same diameters), its errors are the worst over
// the seeds against the reference the table writes, its rows are written beside the table
// (accuracy_cost_adapted.csv) and not into it, and the options are refused out of range (exit 2).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_run.hpp"
#include "core/io.hpp"
#include "test_output.hpp"

namespace rbc {
namespace cli_accuracy_adapted_test {
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

size_t column(const CsvTable& t, const std::string& name) {
  const auto it = std::find(t.header.begin(), t.header.end(), name);
  EXPECT_NE(it, t.header.end()) << name;
  return static_cast<size_t>(it - t.header.begin());
}

TEST(AccuracyTableAdapted, RowsAreTheStretchRunsWorstOverTheMeshSeeds) {
  const fs::path dir = fresh_output_dir("AccuracyTableAdapted_Rows");
  const std::string common =
      "tradeoff --accuracy-table -q --vertices 150 --elements 200 --orders 2 --symmetries none "
      "--spread-max 0 --reference-vertices 300 --reference-seeds 0,1 --adapted-ratios 2,3 "
      "--adapted-seeds 2 --out ";
  const CliRun r = run_rbc(common + quoted(dir / "t") + " --adapted-elements 300", 1);
  ASSERT_EQ(r.exit_code, 0) << r.all();

  const CsvTable cost = read_csv((dir / "t" / "accuracy_cost_adapted.csv").string());
  const CsvTable conv = read_csv((dir / "t" / "convergence_adapted.csv").string());
  const CsvTable ref = read_csv((dir / "t" / "reference.csv").string());
  const CsvTable table = read_csv((dir / "t" / "accuracy_cost.csv").string());
  ASSERT_EQ(cost.rows.size(), 2u);  // size ratios 2 and 3
  // The table itself: the network at 150 and 300 vertices and p = 2 on 200 elements only.
  ASSERT_EQ(table.rows.size(), 3u);
  for (const auto& row : table.rows)
    EXPECT_FALSE(row[column(table, "kind")] == 1 && row[column(table, "resolution")] == 300);
  const size_t nf = ref.rows.size();
  ASSERT_EQ(nf, 13u);
  ASSERT_EQ(conv.rows.size(), 4 * nf);  // two seeds of each ratio, ratio 2 first

  // Each seed's diameters are those of rbc stretch on that adapted mesh.
  std::string forces;
  for (const auto& q : ref.rows) {
    if (!forces.empty()) forces += ',';
    forces += json(q[0]).dump();
  }
  std::vector<double> worst(nf, 0.0);
  for (unsigned seed : {0u, 1u}) {
    const CliRun s = run_rbc(
        "stretch --model continuum --mesh adapted --elements 300 --mesh-size-ratio 2 --order full "
        "--contact-load exact-contact --measure quadric-fit -q --json --no-picture --mesh-seed " +
            std::to_string(seed) + " --force " + forces,
        1);
    ASSERT_EQ(s.exit_code, 0) << s.all();
    const json pts = json::parse(s.out).at("points");
    ASSERT_EQ(pts.size(), nf);
    for (size_t k = 0; k < nf; ++k) {
      const auto& c = conv.rows[seed * nf + k];
      ASSERT_EQ(c[column(conv, "seed")], seed);
      const double a = pts[k].at("axial_um").get<double>(),
                   t = pts[k].at("transverse_um").get<double>();
      EXPECT_NEAR(c[column(conv, "axial_um")], a, 1e-6 * a) << "seed " << seed << " force " << k;
      EXPECT_NEAR(c[column(conv, "transverse_um")], t, 1e-6 * t);
      worst[k] = std::max({worst[k], std::abs(a - ref.rows[k][1]) / ref.rows[k][1],
                           std::abs(t - ref.rows[k][3]) / ref.rows[k][3]});
    }
  }
  // Row errors: the worst over the seeds and D_A, D_T, per force and over all forces.
  const CsvTable by_force = read_csv((dir / "t" / "accuracy_by_force_adapted.csv").string());
  ASSERT_EQ(by_force.rows.size(), 2 * nf);
  for (size_t k = 0; k < nf; ++k)
    EXPECT_NEAR(by_force.rows[k][column(by_force, "error")], worst[k], 1e-6) << k;
  const auto& row = cost.rows[0];
  EXPECT_NEAR(row[column(cost, "error_all")], *std::max_element(worst.begin(), worst.end()), 1e-6);
  EXPECT_EQ(row[column(cost, "rotations")], 2.0);
  EXPECT_EQ(row[column(cost, "size_ratio")], 2.0);
  EXPECT_EQ(row[column(cost, "symmetry")], 0.0);
  EXPECT_GT(row[column(cost, "cost_eg")], 0.0);
  EXPECT_EQ(cost.rows[1][column(cost, "rotations")], 2.0);
  EXPECT_EQ(cost.rows[1][column(cost, "size_ratio")], 3.0);
  double worst3 = 0;  // the ratio-3 row: the worst over its own two seeds
  for (size_t j = 2 * nf; j < 4 * nf; ++j) {
    const auto& c = conv.rows[j];
    const auto& q = ref.rows[j % nf];
    EXPECT_EQ(c[column(conv, "size_ratio")], 3.0);
    worst3 = std::max({worst3, std::abs(c[column(conv, "axial_um")] - q[1]) / q[1],
                       std::abs(c[column(conv, "transverse_um")] - q[3]) / q[3]});
  }
  EXPECT_NEAR(cost.rows[1][column(cost, "error_all")], worst3, 1e-9);
  EXPECT_TRUE(fs::exists(dir / "t" / "runs" / "continuum_adapted2_pfull_E300_r1.csv"));
  EXPECT_TRUE(fs::exists(dir / "t" / "runs" / "continuum_adapted3_pfull_E300_r1.csv"));

  // Out of range: refused before any work, one line, exit 2.
  for (const std::string bad :
       {"--adapted-elements 100", "--adapted-ratios 0.5", "--adapted-ratios nan",
        "--adapted-ratios 2,11", "--adapted-seeds 0", "--adapted-seeds 65"}) {
    const CliRun refused = run_rbc(common + quoted(dir / "bad") + " " + bad);
    EXPECT_EQ(refused.exit_code, 2) << bad << "\n" << refused.all();
    EXPECT_EQ(refused.err.rfind("rbc: error: ", 0), 0u) << refused.all();
    EXPECT_FALSE(fs::exists(dir / "bad" / "runs")) << bad;
  }
}

}  // namespace
}  // namespace cli_accuracy_adapted_test
}  // namespace rbc
