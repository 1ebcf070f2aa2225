// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer --predict FILE` from the command line: a bad held-out file exits 2 naming it before
// any forward run and leaves nothing behind; the predictions reach summary.json, --json, the
// printed summary and a plot; they count their points against their own bands; they are the same
// on 1 and 2 threads, 1 and 3 MPI ranks, and after --resume of the finished run.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "app/cli_run.hpp"
#include "test_output.hpp"

namespace {
namespace fs = std::filesystem;
using rbc::testing::run_rbc;

const char* kHeader = "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n";

std::string write_file(const fs::path& dir, const std::string& name, const std::string& text) {
  const fs::path path = dir / name;
  std::ofstream(path) << text;
  return path.string();
}

std::string read(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The options of a small, cheap inference (200 elements, 20 samples, one Metropolis step).
const std::string kSmall =
    "infer --method continuum:2:200 --sampler tmcmc --samples 20 --chain-length 1 --params "
    "persistence,sigma-scale "
    "--seed 3 ";

std::string tiny(const std::string& data, const fs::path& out, const std::string& extra) {
  return kSmall + "--data-file " + data + " --out " + out.string() + " " + extra;
}

TEST(InferPredictCli, BadHeldOutFileExitsTwoBeforeAnyWorkAndWritesNothing) {
  const fs::path dir = rbc::testing::fresh_output_dir("calibrate_predict_cli_bad");
  const std::string good = "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n";
  const std::string data = write_file(dir, "fit.csv", std::string(kHeader) + good);
  const std::string held = write_file(dir, "held.csv", std::string(kHeader) + good);
  struct Case {
    std::string args, expect;
  };
  const std::vector<Case> cases = {
      {"--predict " + (dir / "missing.csv").string(),
       "rbc: error: --predict " + (dir / "missing.csv").string() + ": cannot open"},
      {"--predict " + write_file(dir, "corrupt.csv", std::string(kHeader) + "0,7.9,0.7,7.9\n"),
       "rbc: error: --predict " + (dir / "corrupt.csv").string() + ": "},
      {"--predict " +
           write_file(dir, "zero_error.csv", std::string(kHeader) + good + "40,11,0,5.1,0.6\n"),
       "axial_err_um 0"},
      {"--predict " +
           write_file(dir, "beyond.csv", std::string(kHeader) + good + "1000,20,0.9,4,0.6\n"),
       "force (continuum model) must be finite and in [0, 400] pN, got 1000 pN"},
      {"--predict " + data, "rbc: error: --predict " + data + ": the data file of the fit itself"},
      {"--predict " + held + " --predict " + held,
       "rbc: error: --predict " + held + ": given twice"},
      {"--predict " + held + " --predict-draws -1",
       "rbc: error: --predict-draws -1: expected a number of posterior draws >= 0"},
  };
  for (const auto& c : cases) {
    const fs::path out = dir / "never";
    fs::remove_all(out);
    const auto r = run_rbc(tiny(data, out, c.args));
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.all();
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.args << "\n" << r.all();
    // One line, and no forward run started.
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.find("beta ="), std::string::npos) << "work started: " << r.err;
    EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out)) << c.args;
  }
}

nlohmann::json predictions_of(const fs::path& out) {
  return nlohmann::json::parse(read(out / "summary.json"))["predictions"];
}

TEST(InferPredictCli, PredictionsReachEveryOutputAndDoNotDependOnThreadsRanksOrResume) {
  const fs::path dir = rbc::testing::fresh_output_dir("calibrate_predict_cli");
  const std::string data = write_file(
      dir, "fit.csv",
      std::string(kHeader) + "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n90,13.8,1.2,4.6,0.6\n");
  const std::string held = write_file(
      dir, "held_out.csv",
      "# name: Lab B cells\n# extra_uncertainty_um: 0.3\n" + std::string(kHeader) +
          "0,7.7,0.6,7.7,0.6\n20,9.6,0.9,6.4,0.6\n60,12.2,1.4,5.0,1.0\n120,16.5,0.3,2.5,0.2\n");
  const std::string held2 = write_file(dir, "second.csv",
                                       std::string(kHeader) +
                                           "15,9.1,0.8,6.7,0.7\n45,11.3,1.3,"
                                           "5.4,1.0\n");
  const std::string predict = "--predict " + held + " --predict " + held2 + " --predict-draws 12";
  const fs::path t1 = dir / "t1";
  const auto r1 = run_rbc(tiny(data, t1, predict + " --json"), 1);
  ASSERT_EQ(r1.exit_code, 0) << r1.all();
  const nlohmann::json j = nlohmann::json::parse(r1.out);
  ASSERT_TRUE(j.contains("predictions")) << r1.out;
  EXPECT_EQ(j["predictions"], predictions_of(t1));
  ASSERT_EQ(j["predictions"].size(), 2u);
  const nlohmann::json& p = j["predictions"][0];
  EXPECT_EQ(p["name"], "Lab B cells");
  EXPECT_EQ(p["path"], held);
  EXPECT_EQ(p["draws"].get<int>(), 12);
  EXPECT_EQ(p["failed_forward_runs"].get<int>(), 0);
  EXPECT_NE(p["sigma"].get<std::string>().find("0.3 um declared"), std::string::npos) << p;
  EXPECT_NE(p["sigma"].get<std::string>().find("sigma-scale"), std::string::npos) << p;
  ASSERT_EQ(p["points"].size(), 4u);
  // The coverage is the count of observed values inside their own bands (independent count
  // here from the per-force quantiles), D_T without the 0 pN point.
  int a50 = 0, a90 = 0, t50 = 0, t90 = 0, tn = 0;
  for (const auto& pt : p["points"]) {
    const auto& a = pt["axial_um"];
    const auto& t = pt["transverse_um"];
    EXPECT_LE(a["q05"].get<double>(), a["q25"].get<double>());
    EXPECT_LE(a["q25"].get<double>(), a["q50"].get<double>());
    EXPECT_LE(a["q50"].get<double>(), a["q75"].get<double>());
    EXPECT_LE(a["q75"].get<double>(), a["q95"].get<double>());
    const auto in = [](const nlohmann::json& v, const char* lo, const char* hi) {
      const double y = v["observed"].get<double>();
      return v[lo].get<double>() <= y && y <= v[hi].get<double>();
    };
    a50 += in(a, "q25", "q75");
    a90 += in(a, "q05", "q95");
    if (!t["used"].get<bool>()) continue;
    ++tn;
    t50 += in(t, "q25", "q75");
    t90 += in(t, "q05", "q95");
  }
  EXPECT_EQ(tn, 3);
  // The 120 pN point lies far outside its bands (small error bars far from the model).
  EXPECT_LT(a90 + t90, 7);
  const auto& cov = p["coverage"];
  EXPECT_EQ(cov["points"]["axial"].get<int>(), 4);
  EXPECT_EQ(cov["points"]["transverse"].get<int>(), 3);
  EXPECT_EQ(cov["inside_50"]["axial"].get<int>(), a50);
  EXPECT_EQ(cov["inside_90"]["axial"].get<int>(), a90);
  EXPECT_EQ(cov["inside_50"]["transverse"].get<int>(), t50);
  EXPECT_EQ(cov["inside_90"]["transverse"].get<int>(), t90);
  EXPECT_DOUBLE_EQ(cov["band_90"]["all"].get<double>(), (a90 + t90) / 7.0);
  // The sigma of a point is its error bar with the declared 0.3 um in quadrature.
  EXPECT_NEAR(p["points"][1]["axial_um"]["sigma"].get<double>(), std::sqrt(0.81 + 0.09), 1e-12);
  // Files: the plot of each prediction with its CSV, in run.json's outputs.
  for (const char* f : {"predict_held_out.png", "predict_held_out.csv", "predict_held_out.gp",
                        "predict_second.png"})
    EXPECT_TRUE(fs::is_regular_file(t1 / f)) << f;
  const std::string csv = read(t1 / "predict_held_out.csv");
  EXPECT_NE(csv.find("# rbc "), std::string::npos) << "the run record heads the CSV\n" << csv;
  const auto run_json = nlohmann::json::parse(read(t1 / "run.json"));
  EXPECT_NE(run_json["outputs"].dump().find("predict_second.png"), std::string::npos);
  EXPECT_EQ(run_json["config"]["predict-draws"].get<int>(), 12);

  // Two threads: the same predictions (and the printed summary names the coverage).
  const fs::path t2 = dir / "t2";
  const auto r2 = run_rbc(tiny(data, t2, predict), 2);
  ASSERT_EQ(r2.exit_code, 0) << r2.all();
  EXPECT_EQ(predictions_of(t2), j["predictions"]);
  EXPECT_NE(r2.out.find("held out: Lab B cells"), std::string::npos) << r2.out;
  EXPECT_NE(r2.out.find("inside the 90 % band"), std::string::npos) << r2.out;

  // --resume of the finished run: no more stages, the same predictions.
  const auto resumed =
      run_rbc(kSmall + "--data-file " + data + " --resume " + t2.string() + " " + predict, 1);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.all();
  EXPECT_EQ(predictions_of(t2), j["predictions"]);

  const std::string mpirun = RBC_MPIRUN;
  if (mpirun.empty()) GTEST_SKIP() << "mpirun not found";
  for (int np : {1, 3}) {
    const fs::path m = dir / ("mpi" + std::to_string(np));
    fs::remove_all(m);
    const std::string cmd = "OMP_WAIT_POLICY=passive " + mpirun +
                            " --allow-run-as-root --oversubscribe -np " + std::to_string(np) +
                            " -x OMP_WAIT_POLICY -x OMP_NUM_THREADS " + RBC_BINARY_DIR + "/rbc " +
                            tiny(data, m, predict + " -q") + " 2>&1";
    FILE* f = popen(cmd.c_str(), "r");
    std::string output;
    char buf[512];
    while (fgets(buf, sizeof buf, f)) output += buf;
    const int status = pclose(f);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << np << " ranks\n" << output;
    EXPECT_EQ(predictions_of(m), j["predictions"]) << np << " ranks";
  }
}

}  // namespace
