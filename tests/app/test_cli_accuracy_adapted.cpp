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
      "--adapted-seeds 2 --no-refined --out ";
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
  EXPECT_FALSE(fs::exists(dir / "t" / "accuracy_cost_refined.csv"));  // --no-refined

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

// `rbc stretch --accuracy P%` chooses among the committed table's rows and the adapted and
// refined rows beside it: the cheapest entry whose error at the force plus the reference's
// standard error meets P, computed here from the three CSV files; a graded-mesh choice runs on
// its mesh with the exact contact load and the quadric fit (the diameters of the table's sweep).
TEST(AccuracyTableAdapted, StretchAccuracyChoosesAmongTheAdaptedRows) {
  const std::string data = std::string(RBC_SOURCE_DIR) + "/data/tradeoff/";
  struct Entry {
    std::string spec;
    double cost = 0, error = 0;
    int resolution = 0;
    bool adapted = false;  // a graded mesh: adapted or refined
    std::string mesh = "uniform";
    double size_ratio = 0;
  };
  std::vector<Entry> entries;
  double se = 0;
  for (const std::string mesh : {"uniform", "adapted", "refined"}) {
    const bool adapted = mesh != "uniform";
    const CsvTable t = read_csv(data + (adapted ? "accuracy_by_force_" + mesh + ".csv"
                                                : std::string("accuracy_by_force.csv")));
    for (const auto& q : t.rows) {
      if (q[column(t, "force_pN")] != 193 || q[column(t, "converged")] != 1) continue;
      se = q[column(t, "reference_se")];
      Entry e;
      e.adapted = adapted;
      e.mesh = mesh;
      if (adapted) e.size_ratio = q[column(t, "size_ratio")];
      e.resolution = static_cast<int>(q[column(t, "resolution")]);
      e.cost = q[column(t, "cost_eg")];
      e.error = q[column(t, "error")];
      const double order = q[column(t, "order")];
      const std::string law = order == 0 ? "full" : std::to_string(static_cast<int>(order));
      if (q[column(t, "kind")] == 0)
        e.spec = "discrete:" + std::to_string(e.resolution);
      else if (!adapted)
        e.spec = "continuum:" + law + ":" + std::to_string(e.resolution);
      else
        e.spec = "continuum-" + mesh + ":" + law + ":" + std::to_string(e.resolution) + ":" +
                 std::to_string(static_cast<int>(q[column(t, "size_ratio")]));
      entries.push_back(e);
    }
  }
  auto cheapest = [&](double percent, bool with_adapted) {
    const Entry* best = nullptr;
    for (const Entry& e : entries)
      if ((with_adapted || !e.adapted) && e.error + se <= percent / 100 &&
          (!best || e.cost < best->cost))
        best = &e;
    return best;
  };
  const Entry* expected = cheapest(0.3, true);
  ASSERT_NE(expected, nullptr);
  ASSERT_TRUE(expected->adapted) << "the committed table does not choose a graded-mesh row at "
                                    "193 pN and 0.3 %: "
                                 << expected->spec;

  const CliRun r = run_rbc("stretch --accuracy 0.3% --force 193 -q --json --no-picture", 1);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const json point = json::parse(r.out).at("points").at(0);
  EXPECT_EQ(point.at("accuracy_choice").at("chosen").at("method"), expected->spec);
  // The run is the table's seed-0 sweep at 193 pN (its mesh and its diameters).
  const CsvTable conv = read_csv(data + "convergence_" + expected->mesh + ".csv");
  bool found = false;
  for (const auto& c : conv.rows)
    if (c[column(conv, "resolution")] == expected->resolution && c[column(conv, "seed")] == 0 &&
        c[column(conv, "size_ratio")] == expected->size_ratio &&
        c[column(conv, "force_pN")] == 193) {
      found = true;
      EXPECT_EQ(point.at("elements").get<double>(), c[column(conv, "elements")]);
      EXPECT_NEAR(point.at("axial_um").get<double>(), c[column(conv, "axial_um")], 1e-5);
      EXPECT_NEAR(point.at("transverse_um").get<double>(), c[column(conv, "transverse_um")], 1e-5);
    }
  EXPECT_TRUE(found);

  // With --contact-load given, the adapted rows (measured with the exact contact load) are left
  // out of the choice.
  const CliRun uniform = run_rbc(
      "stretch --accuracy 0.3% --force 193 -q --json --no-picture --contact-load vertex-patch", 1);
  ASSERT_EQ(uniform.exit_code, 0) << uniform.all();
  EXPECT_EQ(
      json::parse(uniform.out).at("points").at(0).at("accuracy_choice").at("chosen").at("method"),
      cheapest(0.3, false)->spec);
  // The table chooses the size ratio.
  const CliRun refused = run_rbc("stretch --accuracy 0.3% --force 193 -q --mesh-size-ratio 3");
  EXPECT_EQ(refused.exit_code, 2) << refused.all();
  EXPECT_EQ(refused.err.rfind("rbc: error: ", 0), 0u) << refused.all();
}

}  // namespace
}  // namespace cli_accuracy_adapted_test
}  // namespace rbc
