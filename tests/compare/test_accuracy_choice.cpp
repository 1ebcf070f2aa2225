// SPDX-License-Identifier: GPL-3.0-or-later
// The accuracy-cost study's pieces on synthetic data: Richardson chains, the reference
// statistics, the table file, and the --accuracy choice with each of its refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include "compare/accuracy_choice.hpp"
#include "compare/accuracy_study.hpp"
#include "core/io.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

TEST(AccuracyStudy, RichardsonRecoversOrderAndLimitOfASmoothChain) {
  // v(h) = L + c h^p + d h^(p+1) at h = 1, 1/2, 1/4: observed order p to O(h), limit to
  // O(h^(p+1)); for d = 0 both are exact.
  for (double p : {1.0, 2.0}) {
    auto v = [&](double h) { return 11.77 + 0.3 * std::pow(h, p); };
    const Richardson r = richardson_chain(v(1), v(0.5), v(0.25));
    EXPECT_TRUE(r.clean);
    EXPECT_NEAR(r.order, p, 1e-9);
    EXPECT_NEAR(r.limit, 11.77, 1e-12);
  }
  // A scattering chain (differences of opposite sign) has no observed order.
  const Richardson s = richardson_chain(11.978, 11.704, 11.792);
  EXPECT_FALSE(s.clean);
  EXPECT_EQ(s.limit, 11.792);  // falls back to the finest value
}

TEST(AccuracyStudy, ObservedOrderIsTheSlopeInMeshSize) {
  // error = 3 h^2 with h = N^-1/2, i.e. 3/N: order 2 exactly; 1/sqrt(N): order 1.
  const std::vector<double> n = {250, 1000, 4000, 16000};
  std::vector<double> e2, e1;
  for (double v : n) e2.push_back(3 / v), e1.push_back(0.1 / std::sqrt(v));
  EXPECT_NEAR(observed_order(n, e2), 2.0, 1e-12);
  EXPECT_NEAR(observed_order(n, e1), 1.0, 1e-12);
  EXPECT_EQ(observed_order({1000}, {0.01}), 0.0);
}

/// A synthetic run: D_A = a + slope F, D_T = t - 0.01 F at the given forces.
StudyRun synthetic_run(MethodKind kind, int resolution, unsigned seed, double a, double t,
                       double cpu_s, const std::vector<double>& forces, bool reference = false) {
  StudyRun s;
  s.reference = reference;
  s.run.method = {kind, resolution,
                  kind == MethodKind::discrete ? WlcExpansion::full : WlcExpansion::order2, seed};
  s.run.vertices = resolution;
  s.run.elements = 2 * resolution - 4;
  for (double f : forces)
    s.run.points.push_back({f, a + 0.02 * f, t - 0.01 * f, 0.1, 1e-6, 10, true});
  s.run.cpu_s = cpu_s;
  s.run.eval_cpu_s = 1e-4;
  s.unit_eval_cpu_s = 2e-4;
  return s;
}

TEST(AccuracyStudy, ReferenceIsTheMeanOverRotationsAndErrorsAreRelative) {
  AccuracyStudyOptions o;
  o.forces_pN = {0, 50, 150};
  o.reference_vertices = 27500;
  o.reference_seeds = {0, 1, 2};
  std::vector<StudyRun> runs;
  // Reference sweeps (their own tolerance): D_A(0) = 8, 8.1, 7.9 -> mean 8, sd 0.1; D_T(0) = 8.
  runs.push_back(synthetic_run(MethodKind::discrete, 27500, 0, 8.0, 8.0, 100, o.forces_pN, true));
  runs.push_back(synthetic_run(MethodKind::discrete, 27500, 1, 8.1, 8.0, 100, o.forces_pN, true));
  runs.push_back(synthetic_run(MethodKind::discrete, 27500, 2, 7.9, 8.0, 100, o.forces_pN, true));
  // The reference size at the default tolerance: a table entry (0.5 % long), not the reference.
  runs.push_back(synthetic_run(MethodKind::discrete, 27500, 0, 8.04, 8.0, 50, o.forces_pN));
  // A coarse network 2 % long in D_A at 0 pN, and a rotation of it 1 % long.
  runs.push_back(synthetic_run(MethodKind::discrete, 500, 0, 8.16, 8.0, 1, o.forces_pN));
  runs.push_back(synthetic_run(MethodKind::discrete, 500, 1, 8.08, 8.0, 1, o.forces_pN));
  const AccuracyStudy st = assemble_accuracy_study(o, runs);
  ASSERT_EQ(st.reference.size(), 3u);
  EXPECT_NEAR(st.reference[0].axial_um, 8.0, 1e-12);
  EXPECT_NEAR(st.reference[0].axial_sd_um, 0.1, 1e-12);
  EXPECT_NEAR(st.reference_relative_sd, 0.1 / 8.0, 1e-12);  // largest at F = 0 (smallest D_A)
  EXPECT_NEAR(st.reference_relative_se, 0.1 / 8.0 / std::sqrt(3.0), 1e-12);
  ASSERT_EQ(st.rows.size(), 2u);  // N = 500 and the reference size's table sweep
  EXPECT_EQ(st.rows[1].method.resolution, 27500);
  EXPECT_EQ(st.rows[1].rotations, 1);  // the reference sweeps are not its rotations
  EXPECT_NEAR(st.rows[1].error_by_force[0], 0.04 / 8.0, 1e-12);
  const AccuracyRow& r = st.rows[0];
  EXPECT_EQ(r.method.resolution, 500);
  EXPECT_NEAR(r.error_by_force[0], 0.16 / 8.0, 1e-12);
  EXPECT_NEAR(r.error_by_force[2], 0.16 / (8.0 + 3.0), 1e-12);
  EXPECT_NEAR(r.error_all, 0.02, 1e-12);
  EXPECT_NEAR(r.error_low, 0.02, 1e-12);
  EXPECT_NEAR(r.error_mid, 0.16 / 9.0, 1e-12);  // 50 pN is in the middle range
  EXPECT_NEAR(r.error_high, 0.16 / 11.0, 1e-12);
  EXPECT_NEAR(r.cost_eg, 1 / 2e-4, 1e-9);
  EXPECT_NEAR(r.own_eg, 1 / 1e-4, 1e-9);
  EXPECT_NEAR(r.spread, std::sqrt(0.0032) / 8.12, 1e-9);  // sd of 8.16, 8.08 over their mean
}

TEST(AccuracyStudy, MirrorRowsShareTheMeshErrorsButNotTheReferenceOrTheCost) {
  // A mirror sweep of the default mesh is its own row, with its own cost; its errors are
  // taken over the rotations and its own sweep (not the full sweep of the same mesh), and it
  // never enters the reference mean.
  AccuracyStudyOptions o;
  o.forces_pN = {0, 50, 150};
  o.reference_vertices = 27500;
  o.reference_seeds = {0, 1};
  std::vector<StudyRun> runs;
  runs.push_back(synthetic_run(MethodKind::discrete, 27500, 0, 8.0, 8.0, 100, o.forces_pN, true));
  runs.push_back(synthetic_run(MethodKind::discrete, 27500, 1, 8.2, 8.0, 100, o.forces_pN, true));
  runs.push_back(synthetic_run(MethodKind::discrete, 27500, 0, 8.0, 8.0, 50, o.forces_pN));
  StudyRun far = synthetic_run(MethodKind::discrete, 27500, 0, 9.0, 8.0, 40, o.forces_pN);
  far.run.symmetry = Symmetry::mirror;  // would move the reference mean if it were counted
  runs.push_back(far);
  runs.push_back(synthetic_run(MethodKind::discrete, 500, 0, 8.3, 8.0, 4, o.forces_pN));
  StudyRun mirror = synthetic_run(MethodKind::discrete, 500, 0, 8.1, 8.0, 1, o.forces_pN);
  mirror.run.symmetry = Symmetry::mirror;
  runs.push_back(mirror);
  runs.push_back(synthetic_run(MethodKind::discrete, 500, 1, 8.2, 8.0, 4, o.forces_pN));
  const AccuracyStudy st = assemble_accuracy_study(o, runs);
  EXPECT_NEAR(st.reference[0].axial_um, 8.1, 1e-12);  // (8.0 + 8.2)/2: reference sweeps only
  ASSERT_EQ(st.rows.size(), 4u);                      // N = 500 and 27,500, each full and mirror
  auto row = [&](int resolution, Symmetry symmetry) -> const AccuracyRow& {
    for (const auto& r : st.rows)
      if (r.method.resolution == resolution && r.symmetry == symmetry) return r;
    throw std::runtime_error("row missing");
  };
  const AccuracyRow &full = row(500, Symmetry::none), &mir = row(500, Symmetry::mirror);
  EXPECT_EQ(full.method.resolution, 500);
  EXPECT_EQ(full.symmetry, Symmetry::none);
  EXPECT_EQ(mir.method.resolution, 500);
  EXPECT_EQ(mir.symmetry, Symmetry::mirror);
  EXPECT_EQ(full.rotations, 2);  // its own sweep and the rotation
  EXPECT_EQ(mir.rotations, 2);
  EXPECT_NEAR(full.error_by_force[0], 0.2 / 8.1, 1e-12);  // worst of 8.3 and 8.2
  EXPECT_NEAR(mir.error_by_force[0], 0.1 / 8.1, 1e-12);   // worst of 8.1 and 8.2
  EXPECT_NEAR(mir.error_default, 0.0, 1e-12);
  EXPECT_NEAR(full.cost_eg, 4 / 2e-4, 1e-9);
  EXPECT_NEAR(mir.cost_eg, 1 / 2e-4, 1e-9);
  // The verdict names the solver path of the cheapest entry.
  EXPECT_NE(accuracy_study_verdict(st).find("discrete:500 mirror"), std::string::npos);
}

AccuracyEntry entry(MethodKind kind, int resolution, double cost, std::vector<double> error) {
  AccuracyEntry e;
  e.method = {kind, resolution,
              kind == MethodKind::discrete ? WlcExpansion::full : WlcExpansion::order2};
  e.converged = true;
  e.cost_eg = cost;
  e.forces_pN = {0, 50, 100, 200};
  e.error = std::move(error);
  return e;
}

AccuracyTable synthetic_table() {
  AccuracyTable t;
  t.source = "synthetic";
  t.reference_relative_se = 0.001;
  t.entries.push_back(entry(MethodKind::discrete, 250, 100, {0.010, 0.020, 0.030, 0.040}));
  t.entries.push_back(entry(MethodKind::continuum, 500, 150, {0.030, 0.008, 0.006, 0.004}));
  t.entries.push_back(entry(MethodKind::discrete, 1000, 400, {0.004, 0.004, 0.005, 0.005}));
  t.entries.push_back(entry(MethodKind::continuum, 2000, 900, {0.002, 0.002, 0.002, 0.002}));
  AccuracyEntry broken = entry(MethodKind::discrete, 100, 1, {0, 0, 0, 0});
  broken.converged = false;  // never chosen, however cheap and accurate
  t.entries.push_back(broken);
  return t;
}

TEST(AccuracyChoice, PicksTheCheapestEntryMeetingTheAccuracyOverTheForces) {
  const AccuracyTable t = synthetic_table();
  // Low forces, 2 %: N = 250 (1 % at 0 pN; 0 and 50 pN -> 2 % at 50 pN > 2 % - 0.1 %).
  EXPECT_EQ(choose_by_accuracy(t, {0}, 2).chosen.method.resolution, 250);
  EXPECT_EQ(choose_by_accuracy(t, {0, 50}, 2).chosen.method.resolution, 1000);
  // High forces, 1 %: the continuum at 500 elements is cheapest.
  const AccuracyChoice hi = choose_by_accuracy(t, {100, 200}, 1);
  EXPECT_EQ(hi.chosen.method.kind, MethodKind::continuum);
  EXPECT_EQ(hi.chosen.method.resolution, 500);
  EXPECT_NEAR(hi.chosen.error, 0.006, 1e-15);
  ASSERT_TRUE(hi.runner_up);
  EXPECT_EQ(hi.runner_up->method.resolution, 1000);  // discrete, the next cheapest
  EXPECT_FALSE(hi.other_kind);                       // ... which is the runner-up already
  EXPECT_NE(hi.reason.find("continuum:2:500"), std::string::npos);
  EXPECT_NE(hi.reason.find("runner-up discrete:1000"), std::string::npos);
  // A force between table forces takes the larger neighbouring error: 25 pN for the
  // continuum is max(3 %, 0.8 %) = 3 %.
  EXPECT_NEAR(entry_error(t.entries[1], {25}), 0.030, 1e-15);
  EXPECT_NEAR(entry_error(t.entries[1], {50}), 0.008, 1e-15);
  EXPECT_NEAR(entry_error(t.entries[1], {150, 200}), 0.006, 1e-15);
  // The reference uncertainty counts: 0.5 % at 100 pN is met by N = 1000 (0.5 %) only
  // without it; with 0.1 % added, the 2,000-element continuum is needed.
  EXPECT_EQ(choose_by_accuracy(t, {100}, 0.5).chosen.method.resolution, 2000);
  AccuracyTable exact = t;
  exact.reference_relative_se = 0;
  EXPECT_EQ(choose_by_accuracy(exact, {100}, 0.5).chosen.method.resolution, 1000);
}

TEST(AccuracyChoice, ChoosesTheSolverPathUnlessTheUserFixedIt) {
  AccuracyTable t = synthetic_table();
  AccuracyEntry mirror = t.entries[2];  // discrete N = 1000 at 40 % of the cost
  mirror.symmetry = Symmetry::mirror;
  mirror.cost_eg = 160;
  t.entries.push_back(mirror);
  // 0.6 % at 0 and 50 pN: only N = 1000 and the 2,000-element continuum qualify.
  const AccuracyChoice any = choose_by_accuracy(t, {0, 50}, 0.6);
  EXPECT_EQ(any.chosen.method.resolution, 1000);
  EXPECT_EQ(any.chosen.symmetry, Symmetry::mirror);
  ASSERT_TRUE(any.runner_up);  // the same mesh on the full path is no alternative
  EXPECT_EQ(any.runner_up->method.resolution, 2000);
  EXPECT_NE(any.reason.find("chose discrete:1000 mirror"), std::string::npos) << any.reason;
  const AccuracyChoice full = choose_by_accuracy(t, {0, 50}, 0.6, Symmetry::none);
  EXPECT_EQ(full.chosen.method.resolution, 1000);
  EXPECT_EQ(full.chosen.symmetry, Symmetry::none);
  EXPECT_EQ(full.chosen.cost_eg, 400);
  // Restricted to mirror rows, 2 % at 0 pN has no N = 250 to choose: N = 1000 mirror.
  EXPECT_EQ(choose_by_accuracy(t, {0}, 2, Symmetry::mirror).chosen.method.resolution, 1000);
  EXPECT_THROW(choose_by_accuracy(t, {0, 200}, 0.4, Symmetry::mirror), std::invalid_argument);
}

TEST(AccuracyChoice, RefusesWhatTheTableCannotAnswer) {
  const AccuracyTable t = synthetic_table();
  const double inf = std::numeric_limits<double>::infinity();
  for (double p : {0.0, -1.0, inf, std::nan("")})
    EXPECT_THROW(choose_by_accuracy(t, {50}, p), std::invalid_argument) << p;
  EXPECT_THROW(choose_by_accuracy(t, {}, 1), std::invalid_argument);
  try {
    choose_by_accuracy(t, {50, 250}, 1);
    ADD_FAILURE() << "force outside the table accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("250 pN lies outside"), std::string::npos) << e.what();
  }
  try {
    choose_by_accuracy(t, {0, 200}, 0.25);  // best is 0.2 % + 0.1 % reference
    ADD_FAILURE() << "unreachable accuracy accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no method"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("continuum:2:2000"), std::string::npos) << e.what();
  }
  // A table without mirror rows (e.g. an older one): --symmetry mirror names that, rather than
  // an accuracy no method reaches.
  try {
    choose_by_accuracy(t, {0}, 5, Symmetry::mirror);
    ADD_FAILURE() << "--symmetry mirror accepted on a table without mirror rows";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no rows solved with --symmetry mirror"),
              std::string::npos)
        << e.what();
  }
}

TEST(AccuracyStudy, SolverPathsMustIncludeTheFullSweeps) {
  AccuracyStudyOptions o;
  o.symmetries = {Symmetry::mirror};
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.symmetries = {Symmetry::mirror, Symmetry::none};
  EXPECT_NO_THROW(o.validate());
}

TEST(AccuracyChoice, ParsesPercentages) {
  EXPECT_EQ(parse_accuracy_percent("1%"), 1.0);
  EXPECT_EQ(parse_accuracy_percent("0.5 %"), 0.5);
  EXPECT_EQ(parse_accuracy_percent("2"), 2.0);
  for (const char* bad : {"", "%", "abc", "1%%", "0", "-1%", "inf", "nan", "1e999", "101", "1 x"})
    EXPECT_THROW(parse_accuracy_percent(bad), std::invalid_argument) << bad;
}

TEST(AccuracyChoice, TableFileRoundTripsAndRefusesMalformedFiles) {
  namespace fs = std::filesystem;
  const fs::path dir = testing::fresh_output_dir("accuracy_table_round_trip");
  auto write = [&](const std::string& name, const std::string& text) {
    const std::string path = (dir / name).string();
    std::ofstream(path) << text;
    return path;
  };
  const AccuracyTable t = load_accuracy_table(
      write("good.csv",
            "# synthetic\nkind,order,resolution,converged,cost_eg,force_pN,error,reference_se\n"
            "0,0,250,1,100,0,0.01,0.001\n0,0,250,1,100,193,0.02,0.001\n"
            "1,2,500,1,150,0,0.03,0.001\n1,2,500,1,150,193,0.004,0.001\n"));
  ASSERT_EQ(t.entries.size(), 2u);
  EXPECT_EQ(t.entries[1].method.kind, MethodKind::continuum);
  EXPECT_EQ(t.entries[1].method.order, WlcExpansion::order2);
  EXPECT_EQ(t.entries[1].forces_pN.back(), 193);
  EXPECT_EQ(t.reference_relative_se, 0.001);
  EXPECT_EQ(method_spec(choose_by_accuracy(t, {150}, 2.5).chosen.method), "discrete:250");
  EXPECT_EQ(t.entries[0].symmetry, Symmetry::none);  // a table without the symmetry column
  // With the symmetry column: the same mesh on two solver paths is two entries.
  const AccuracyTable ts = load_accuracy_table(
      write("with_symmetry.csv",
            "kind,order,resolution,converged,cost_eg,force_pN,error,reference_se,symmetry\n"
            "0,0,250,1,100,0,0.01,0.001,0\n0,0,250,1,100,193,0.02,0.001,0\n"
            "0,0,250,1,60,0,0.01,0.001,1\n0,0,250,1,60,193,0.02,0.001,1\n"));
  ASSERT_EQ(ts.entries.size(), 2u);
  EXPECT_EQ(ts.entries[1].symmetry, Symmetry::mirror);
  EXPECT_EQ(choose_by_accuracy(ts, {150}, 2.5).chosen.symmetry, Symmetry::mirror);
  const std::vector<std::string> bad = {
      "kind,order,resolution,converged,cost_eg,force_pN,error\n0,0,250,1,100,0,0.01\n",
      "kind,order,resolution,converged,cost_eg,force_pN,error,reference_se\n"
      "0,0,250,1,100,50,0.01,0\n0,0,250,1,100,0,0.01,0\n",  // decreasing forces
      "kind,order,resolution,converged,cost_eg,force_pN,error,reference_se\n"
      "1,5,500,1,100,0,0.01,0\n",  // unknown order
      "kind,order,resolution,converged,cost_eg,force_pN,error,reference_se\n"
      "0,0,250,1,100,0,0.01,0\n1,2,500,1,1,0,0.1,0\n0,0,250,1,100,50,0.01,0\n",  // split
      "kind,order,resolution,converged,cost_eg,force_pN,error,reference_se\n",   // no rows
      "kind,order,resolution,converged,cost_eg,force_pN,error,reference_se,symmetry\n"
      "0,0,250,1,100,0,0.01,0,2\n"};  // unknown symmetry code
  for (size_t k = 0; k < bad.size(); ++k) {
    EXPECT_THROW(load_accuracy_table(write("bad" + std::to_string(k) + ".csv", bad[k])),
                 std::runtime_error)
        << bad[k];
  }
  EXPECT_THROW(load_accuracy_table((dir / "missing.csv").string()), std::runtime_error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rbc

namespace rbc {
namespace {

// The committed accuracy_cost.csv reads with its symmetry column, a copy without the column
// reads as all full rows, and a symmetry code other than 0 or 1 is refused.
TEST(AccuracyStudy, CostTableReadsWithOrWithoutTheSymmetryColumn) {
  namespace fs = std::filesystem;
  const std::string committed = std::string(RBC_SOURCE_DIR) + "/data/tradeoff/accuracy_cost.csv";
  const AccuracyCostTable now = load_accuracy_cost(committed);
  ASSERT_FALSE(now.rows.empty());
  bool any_mirror = false;
  for (const AccuracyRow& r : now.rows) any_mirror = any_mirror || r.symmetry == Symmetry::mirror;
  EXPECT_TRUE(any_mirror);
  const fs::path dir = testing::fresh_output_dir("accuracy_cost_symmetry_column");
  std::ifstream in(committed);
  std::ofstream older(dir / "older.csv"), wrong(dir / "wrong.csv");
  std::string line;
  bool header_seen = false;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const std::string cut = line.substr(0, line.rfind(','));  // drop the last column
    older << cut << '\n';
    wrong << (header_seen ? cut + ",2" : line) << '\n';
    header_seen = true;
  }
  older.close();
  wrong.close();
  const AccuracyCostTable old = load_accuracy_cost((dir / "older.csv").string());
  ASSERT_EQ(old.rows.size(), now.rows.size());
  for (size_t k = 0; k < old.rows.size(); ++k) {
    EXPECT_EQ(old.rows[k].symmetry, Symmetry::none);
    EXPECT_EQ(old.rows[k].cost_eg, now.rows[k].cost_eg);
  }
  EXPECT_THROW(load_accuracy_cost((dir / "wrong.csv").string()), std::runtime_error);
  fs::remove_all(dir);
}

// The graded-mesh rows beside the table read with their mesh and size ratio; each file is refused
// as the other kind, and a graded-mesh row that is not a continuum row is refused.
TEST(AccuracyStudy, GradedMeshRowsReadWithTheirMeshAndSizeRatio) {
  namespace fs = std::filesystem;
  const std::string data = std::string(RBC_SOURCE_DIR) + "/data/tradeoff/";
  for (const auto& [file, kind] : {std::pair{"accuracy_cost_adapted.csv", CostRows::adapted},
                                   std::pair{"accuracy_cost_refined.csv", CostRows::refined}}) {
    const CsvTable raw = read_csv(data + file);
    const AccuracyCostTable t = load_accuracy_cost(data + file, kind);
    ASSERT_EQ(t.rows.size(), raw.rows.size()) << file;
    const size_t ratio_column = raw.header.size() - 1;
    ASSERT_EQ(raw.header[ratio_column], "size_ratio");
    for (size_t k = 0; k < t.rows.size(); ++k) {
      const AccuracyRow& r = t.rows[k];
      EXPECT_EQ(r.method.kind, MethodKind::continuum);
      EXPECT_EQ(r.method.adapted, kind == CostRows::adapted) << file << " row " << k;
      EXPECT_EQ(r.method.refined, kind == CostRows::refined);
      EXPECT_EQ(r.method.size_ratio, raw.rows[k][ratio_column]);
      EXPECT_EQ(r.cost_eg, raw.rows[k][10]);
    }
    EXPECT_THROW(load_accuracy_cost(data + file), std::runtime_error) << file << " as the table";
  }
  EXPECT_THROW(load_accuracy_cost(data + "accuracy_cost.csv", CostRows::refined),
               std::runtime_error);
  const fs::path dir = testing::fresh_output_dir("accuracy_cost_graded_rows");
  std::ifstream in(data + "accuracy_cost_refined.csv");
  std::ofstream network(dir / "network.csv");
  std::string line;
  bool header_seen = false;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    network << (header_seen ? "0" + line.substr(line.find(',')) : line) << '\n';  // kind 0
    header_seen = true;
  }
  network.close();
  EXPECT_THROW(load_accuracy_cost((dir / "network.csv").string(), CostRows::refined),
               std::runtime_error);
  fs::remove_all(dir);
}

// The reference sweeps are cached per force tolerance: a tolerance that rounds to the same
// short name, or a file whose stored tolerance differs, is swept again, never reused.
TEST(AccuracyStudy, ReferenceSweepsAreCachedPerTolerance) {
  namespace fs = std::filesystem;
  const fs::path dir = testing::fresh_output_dir("accuracy_reference_cache");
  AccuracyStudyOptions o;
  o.forces_pN = {0.0};
  o.discrete_vertices = {};
  o.continuum_elements = {};
  o.reference_vertices = 100;
  o.reference_seeds = {0};
  o.spread_seeds = {};
  o.symmetries = {Symmetry::none};
  o.cost_unit_vertices = 100;
  o.cache_dir = dir.string();
  o.reference_force_tolerance_pN = 1e-5;
  const auto files = [&] {
    return std::distance(fs::directory_iterator(dir), fs::directory_iterator{});
  };
  const std::vector<StudyRun> first = run_accuracy_sweeps(o, {});
  ASSERT_EQ(first.size(), 2u);  // the reference size's table sweep and the reference sweep
  EXPECT_EQ(static_cast<int>(first[0].reference) + static_cast<int>(first[1].reference), 1);
  EXPECT_EQ(files(), 4);  // a points file and a meta file each
  const std::vector<StudyRun> again = run_accuracy_sweeps(o, {});  // read back
  ASSERT_EQ(again.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(again[k].reference, first[k].reference);
    EXPECT_NEAR(again[k].run.points[0].axial_um, first[k].run.points[0].axial_um, 1e-8);
  }
  o.reference_force_tolerance_pN = 1.4e-5;  // "1e-05" to one digit: swept on its own
  run_accuracy_sweeps(o, {});
  EXPECT_EQ(files(), 6);
  EXPECT_TRUE(fs::exists(dir / "discrete_N100_ref1.4e-05.csv"));
  // A meta file whose stored tolerance is not the one asked for is swept again (rewritten).
  // The tolerance is read and changed as a number in its named column: the timing columns of
  // the same file hold arbitrary numbers, so no text search can tell them apart.
  const std::string meta = (dir / "discrete_N100_ref1e-05.meta.csv").string();
  const auto tolerance_column = [](const CsvTable& t) {
    return static_cast<size_t>(std::find(t.header.begin(), t.header.end(), "force_tolerance_pN") -
                               t.header.begin());
  };
  const auto stored_tolerance = [&] {
    const CsvTable t = read_csv(meta);
    const size_t col = tolerance_column(t);
    if (col >= t.header.size() || t.rows.size() != 1 || t.rows[0].size() <= col) {
      ADD_FAILURE() << meta << " has no single force_tolerance_pN value";
      return -1.0;
    }
    return t.rows[0][col];
  };
  EXPECT_EQ(stored_tolerance(), 1e-5);
  CsvTable edited = read_csv(meta);
  ASSERT_LT(tolerance_column(edited), edited.header.size());
  edited.rows.at(0).at(tolerance_column(edited)) = 2e-5;
  write_csv(meta, edited);
  ASSERT_EQ(stored_tolerance(), 2e-5);
  o.reference_force_tolerance_pN = 1e-5;
  run_accuracy_sweeps(o, {});
  EXPECT_EQ(stored_tolerance(), 1e-5);  // swept again, rewritten at the tolerance asked for
  EXPECT_EQ(files(), 6);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rbc
