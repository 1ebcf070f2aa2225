// SPDX-License-Identifier: GPL-3.0-or-later
// Prediction of held-out recovery data (calibrate/recovery_prediction.hpp, `rbc infer --predict
// CELLS.csv`): synthetic cells made at a known (p, Lmax, eta_m) with the reading noise are
// covered by the predictive of a posterior concentrated at the truth at about the nominal rate;
// eta_m not inferred is drawn from its prior box and widens the bands; the prediction is the same
// on 1 and 2 threads; bad files are refused on the command line before any work, and a good one
// reaches summary.json, the printed summary and a plot.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>

#include "app/cli_run.hpp"
#include "calibrate/infer.hpp"
#include "calibrate/recovery_prediction.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {
namespace fs = std::filesystem;

constexpr double kTruePersistence_nm = 9.0, kTrueLmax_nm = 230.0, kTrueEta_pN_s_per_um = 1.2;
constexpr int kElements = 200;

std::string write_file(const fs::path& dir, const std::string& name, const std::string& text) {
  const fs::path path = dir / name;
  std::ofstream(path) << text;
  return path.string();
}

/// A small stretch data file (the fit's data; nothing is solved on it here).
std::string stretch_file(const fs::path& dir) {
  return write_file(dir, "stretch.csv",
                    "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                    "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n");
}

RecoveryModelOptions release_scene() {
  RecoveryModelOptions r;
  r.elements = kElements;
  return r;
}

/// Three cells at the truth: lambda_inf (1 + r0 g)/(1 - r0 g) at data time t, g at reference
/// time t eta_ref/eta_m, plus N(0, 0.02^2) reading noise (fixed seed), 25 readings each.
std::string synthetic_cells(const fs::path& dir, const std::string& name, unsigned seed) {
  ForwardParameters p;
  p.persistence_nm = kTruePersistence_nm;
  p.lmax_nm = kTrueLmax_nm;
  const RecoveryCurve curve = simulate_recovery(p, release_scene());
  EXPECT_TRUE(curve.converged) << curve.status;
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::ostringstream s;
  s << "cell,time_s,length_over_width\n";
  const double lambda_inf[3] = {1.1, 1.2, 1.3}, lambda_0[3] = {2.0, 1.8, 2.2};
  for (int c = 0; c < 3; ++c) {
    const double r0 = (lambda_0[c] - lambda_inf[c]) / (lambda_0[c] + lambda_inf[c]);
    for (int i = 0; i < 25; ++i) {
      const double t = 0.016 * i;
      const double x = r0 * curve.at(t * curve.eta_ref_pN_s_per_um / kTrueEta_pN_s_per_um);
      s << c + 1 << "," << t << "," << lambda_inf[c] * (1 + x) / (1 - x) + noise(gen) << "\n";
    }
  }
  return write_file(dir, name, s.str());
}

/// A posterior of n samples, every one at the truth (eta_m too when inferred).
InferenceResult at_truth(const InferenceProblem& problem, int n) {
  InferenceResult r;
  r.samples.resize(n, static_cast<int>(problem.slots().size()));
  for (size_t k = 0; k < problem.slots().size(); ++k) {
    double v = 0;
    switch (problem.slots()[k].parameter) {
      case Parameter::persistence:
        v = kTruePersistence_nm;
        break;
      case Parameter::lmax:
        v = kTrueLmax_nm;
        break;
      case Parameter::eta_m:
        v = kTrueEta_pN_s_per_um;
        break;
      default:
        v = 1.0;
    }
    r.samples.col(static_cast<int>(k)).setConstant(v);
  }
  return r;
}

InferOptions stretch_fit(const fs::path& dir) {
  InferOptions o;
  o.data_file = stretch_file(dir);
  o.method = Method{MethodKind::continuum, kElements, WlcExpansion::order2};
  o.parameters = {Parameter::persistence, Parameter::lmax};
  o.recovery_model = release_scene();
  o.threads = 1;
  return o;
}

double mean_band_width(const RecoveryPrediction& p) {
  double w = 0;
  for (const auto& c : p.cells)
    for (int i = 0; i < c.points(); ++i) w += c.q95[i] - c.q05[i];
  return w / p.points();
}

// A joint fit that inferred eta_m, its posterior at the truth: the held-out cells' readings lie
// inside the 90 % band at about 90 % (nominal a little above, the nuisances being fitted to
// them: 75 readings, binomial sd 0.035) and inside the 50 % band at about half. A wrong time
// rescaling or a wrong eta_m puts the band's decay off the readings' and the coverage collapses.
TEST(RecoveryPrediction, PosteriorAtTheTruthCoversSyntheticCellsAtTheNominalRate) {
  const fs::path dir = testing::fresh_output_dir("recovery_prediction_truth");
  InferOptions o = stretch_fit(dir);
  o.data_files = {o.data_file, synthetic_cells(dir, "fitted_cells.csv", 11)};
  o.parameters = {Parameter::persistence, Parameter::lmax, Parameter::eta_m};
  const InferenceProblem problem(o);
  const RecoveryPredictionProblem held(problem, synthetic_cells(dir, "held_cells.csv", 12));
  const RecoveryPrediction p = predict_recovery(held, at_truth(problem, 10), 0);
  EXPECT_TRUE(p.eta_m_inferred);
  EXPECT_EQ(p.eta_m_text(), "eta_m inferred: each draw's own");
  EXPECT_EQ(p.draws, 10);
  EXPECT_EQ(p.trajectories, 1);
  EXPECT_EQ(p.used_draws, 10);
  ASSERT_EQ(p.cells.size(), 3u);
  EXPECT_EQ(p.points(), 75);
  EXPECT_GE(p.fraction_90(), 0.80);
  EXPECT_LE(p.fraction_90(), 0.99);
  EXPECT_GE(p.fraction_50(), 0.35);
  EXPECT_LE(p.fraction_50(), 0.70);
  for (const auto& c : p.cells) {
    EXPECT_GE(c.in_90, 19) << "cell " << c.id;
    // Every draw the same: the band is the model curve +- the quantiles of N(0, 0.02^2).
    for (int i = 0; i < c.points(); ++i) {
      EXPECT_NEAR(c.q95[i] - c.q05[i], 2 * 1.6448536 * 0.02, 1e-6);
      EXPECT_NEAR(c.q75[i] - c.q25[i], 2 * 0.6744898 * 0.02, 1e-6);
      EXPECT_NEAR(c.q50[i], 0.5 * (c.q05[i] + c.q95[i]), 1e-9);
    }
  }
  // The nuisances' modes near the cells' truths (1.1, 1.2, 1.3 and 2.0, 1.8, 2.2).
  EXPECT_NEAR(p.cells[0].lambda_inf, 1.1, 0.05);
  EXPECT_NEAR(p.cells[2].lambda_0, 2.2, 0.05);
  // t_c = eta_m/mu, every draw at the truth.
  EXPECT_NEAR(p.tc_q05_s, p.tc_q95_s, 1e-12);
  EXPECT_NEAR(p.eta_m_q50, kTrueEta_pN_s_per_um, 1e-12);
  // The JSON entry: kind, per-cell arrays and the coverage.
  const nlohmann::json j = recovery_prediction_json(p);
  EXPECT_EQ(j["kind"], "recovery");
  EXPECT_EQ(j["cells"].size(), 3u);
  EXPECT_EQ(j["cells"][1]["time_s"].size(), 25u);
  EXPECT_EQ(j["coverage"]["inside_90"], p.in_90());
  EXPECT_DOUBLE_EQ(j["cells"][0]["normalised_recovery"]["q50"][3].get<double>(),
                   p.cells[0].normalised(p.cells[0].q50[3]));
}

// A stretch-only fit: eta_m is drawn from its prior box (0.2 to 2 pN s/um), which the summary
// says; the draws spread over the box, t_c = eta_m/mu follows them, and the bands are wider than
// with eta_m known, covering the readings at least as often.
TEST(RecoveryPrediction, EtaNotInferredIsDrawnFromItsPriorAndWidensTheBands) {
  const fs::path dir = testing::fresh_output_dir("recovery_prediction_prior");
  const InferenceProblem problem(stretch_fit(dir));
  const RecoveryPredictionProblem held(problem, synthetic_cells(dir, "held_cells.csv", 12));
  const RecoveryPrediction p = predict_recovery(held, at_truth(problem, 40), 0);
  EXPECT_FALSE(p.eta_m_inferred);
  EXPECT_EQ(p.eta_m_text(), "eta_m not inferred: drawn from its prior 0.2 to 2 pN s/um");
  EXPECT_EQ(p.trajectories, 1);
  EXPECT_GE(p.eta_m_q05, 0.2);
  EXPECT_LT(p.eta_m_q05, 0.5);
  EXPECT_GT(p.eta_m_q95, 1.7);
  EXPECT_LE(p.eta_m_q95, 2.0);
  EXPECT_NEAR(p.tc_q95_s / p.tc_q05_s, p.eta_m_q95 / p.eta_m_q05, 1e-9);
  EXPECT_GE(p.fraction_90(), 0.8);
  EXPECT_GT(mean_band_width(p), 1.2 * 2 * 1.6448536 * 0.02);
}

// The trajectories run on any thread count to the same prediction, bit for bit.
TEST(RecoveryPrediction, SameOnOneAndTwoThreads) {
  const fs::path dir = testing::fresh_output_dir("recovery_prediction_threads");
  const InferenceProblem problem(stretch_fit(dir));
  const RecoveryPredictionProblem held(problem, synthetic_cells(dir, "held_cells.csv", 12));
  InferenceResult fit = at_truth(problem, 6);
  for (int i = 0; i < 6; ++i) fit.samples(i, 0) = 7.0 + (i % 3);  // three distinct runs
  const RecoveryPrediction one =
      predict_recovery(held, fit, 5, omp_executor(problem.prior(), held.runner(), 1));
  const RecoveryPrediction two =
      predict_recovery(held, fit, 5, omp_executor(problem.prior(), held.runner(), 2));
  EXPECT_EQ(one.draws, 5);
  EXPECT_EQ(one.trajectories, two.trajectories);
  ASSERT_EQ(one.cells.size(), two.cells.size());
  for (size_t c = 0; c < one.cells.size(); ++c) {
    EXPECT_EQ(one.cells[c].q05, two.cells[c].q05);
    EXPECT_EQ(one.cells[c].q50, two.cells[c].q50);
    EXPECT_EQ(one.cells[c].q95, two.cells[c].q95);
    EXPECT_EQ(one.cells[c].lambda_inf, two.cells[c].lambda_inf);
  }
  EXPECT_EQ(one.tc_q50_s, two.tc_q50_s);
}

/// The options of a small, cheap inference (200 elements, 20 samples, one Metropolis step).
const std::string kSmall =
    "infer --method continuum:2:200 --sampler tmcmc --samples 20 --chain-length 1 --seed 3 ";

// A bad recovery file (or draw count) exits 2 with one line naming it, before any forward run.
TEST(RecoveryPredictionCli, BadRecoveryFileExitsTwoBeforeAnyWork) {
  const fs::path dir = testing::fresh_output_dir("recovery_prediction_cli_bad");
  const std::string data = stretch_file(dir);
  const std::string head = "cell,time_s,length_over_width\n1,0,2.0\n1,0.1,1.6\n";
  const std::string good = write_file(dir, "good.csv", head + "1,0.2,1.4\n");
  struct Case {
    std::string args, expect;
    std::string params = "persistence";
  };
  const std::vector<Case> cases = {
      {"--predict " + write_file(dir, "value.csv", head + "1,0.2,abc\n"),
       "rbc: error: --predict " + (dir / "value.csv").string() + ": recovery data file '" +
           (dir / "value.csv").string() + "' line 4 must be a finite number, got 'abc'"},
      {"--predict " + write_file(dir, "short.csv", head),
       "rbc: error: --predict " + (dir / "short.csv").string() + ": "},
      {"--predict " +
           write_file(dir, "split.csv", head + "2,0,2\n2,0.1,1.5\n2,0.2,1.3\n1,0.3,1.2\n"),
       "rbc: error: --predict " + (dir / "split.csv").string() + ": "},
      {"--predict " + write_file(dir, "columns.csv", "cell,time_s\n1,0\n1,0.1\n1,0.2\n"),
       "rbc: error: --predict " + (dir / "columns.csv").string() + ": "},
      {"--predict " + good + " --predict-recovery-draws -1",
       "rbc: error: --predict-recovery-draws -1: expected a number of posterior draws >= 0"},
      {"--predict " + good + " --data-file " + good,
       "rbc: error: --predict " + good + ": one of the fit's data files", "persistence,eta-m"},
  };
  for (const auto& c : cases) {
    const fs::path out = dir / "never";
    fs::remove_all(out);
    const auto r = testing::run_rbc(kSmall + "--params " + c.params + " --data-file " + data +
                                    " --out " + out.string() + " " + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.all();
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.args << "\n" << r.all();
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.find("beta ="), std::string::npos) << "work started: " << r.err;
    EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out)) << c.args;
  }
}

// A recovery file after a stretch fit: summary.json's "predictions" gets the kind "recovery"
// entry with its cells, the summary says how eta_m entered, the plot is written.
TEST(RecoveryPredictionCli, PredictsARecoveryFileIntoSummaryAndPlot) {
  const fs::path dir = testing::fresh_output_dir("recovery_prediction_cli_good");
  const std::string data = stretch_file(dir);
  const std::string held = synthetic_cells(dir, "held_cells.csv", 12);
  const fs::path out = dir / "out";
  const auto r = testing::run_rbc(kSmall + "--params persistence --recovery-elements 200 " +
                                      "--data-file " + data + " --out " + out.string() +
                                      " --predict " + held + " --predict-recovery-draws 3",
                                  2);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  EXPECT_NE(r.out.find("eta_m not inferred: drawn from its prior 0.2 to 2 pN s/um"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("predict_held_cells.png"), std::string::npos) << r.out;
  std::ifstream in(out / "summary.json");
  const nlohmann::json s = nlohmann::json::parse(in);
  ASSERT_EQ(s["predictions"].size(), 1u) << s["predictions"].dump();
  const nlohmann::json& p = s["predictions"][0];
  EXPECT_EQ(p["kind"], "recovery");
  EXPECT_EQ(p["draws"], 3);
  EXPECT_EQ(p["cells"].size(), 3u);
  EXPECT_EQ(p["coverage"]["points"], 75);
  EXPECT_TRUE(fs::exists(out / "predict_held_cells.png"));
  EXPECT_TRUE(fs::exists(out / "predict_held_cells.csv"));
  EXPECT_TRUE(fs::exists(out / "predict_held_cells_cell2.csv"));

  // The same predictions on one thread and on 3 MPI ranks (the trajectories through the
  // master-worker pool).
  const std::string args = kSmall + "--params persistence --recovery-elements 200 --data-file " +
                           data + " --predict " + held + " --predict-recovery-draws 3 -q --out ";
  const fs::path one = dir / "one";
  const auto r1 = testing::run_rbc(args + one.string(), 1);
  ASSERT_EQ(r1.exit_code, 0) << r1.all();
  const auto predictions = [](const fs::path& d) {
    std::ifstream f(d / "summary.json");
    return nlohmann::json::parse(f)["predictions"];
  };
  EXPECT_EQ(predictions(one), s["predictions"]);
  const std::string mpirun = RBC_MPIRUN;
  if (mpirun.empty()) GTEST_SKIP() << "mpirun not found";
  const fs::path mpi = dir / "mpi3";
  const std::string cmd = "OMP_WAIT_POLICY=passive OMP_NUM_THREADS=1 " + mpirun +
                          " --allow-run-as-root --oversubscribe -np 3 -x OMP_WAIT_POLICY -x "
                          "OMP_NUM_THREADS " +
                          RBC_BINARY_DIR + "/rbc " + args + mpi.string() + " 2>&1";
  FILE* f = popen(cmd.c_str(), "r");
  std::string output;
  char buf[512];
  while (fgets(buf, sizeof buf, f)) output += buf;
  const int status = pclose(f);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << output;
  EXPECT_EQ(predictions(mpi), s["predictions"]);
}

}  // namespace
}  // namespace rbc
