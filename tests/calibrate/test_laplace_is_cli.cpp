// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer --sampler laplace-is` on a small problem (continuum p = 2 on 200 elements, three
// forces, persistence and sigma-scale): it runs, its posterior medians lie inside TMCMC's 90 %
// intervals on the same problem, it is identical on 1 and 2 threads, and the input it cannot
// take is refused before any work.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "app/cli_run.hpp"
#include "test_output.hpp"

namespace {
namespace fs = std::filesystem;
using rbc::testing::run_rbc;

std::string read(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

nlohmann::json without_timing(const fs::path& p) {
  nlohmann::json j = nlohmann::json::parse(read(p));
  for (const char* k : {"timing", "command", "provenance"}) j.erase(k);
  if (j.contains("config")) j["config"].erase("out");
  return j;
}

fs::path small_data(const fs::path& dir) {
  const fs::path p = dir / "small.csv";
  std::ofstream(p) << "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                      "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n90,13.8,1.2,4.6,0.6\n";
  return p;
}

const std::string kCommon =
    " -q --method continuum:2:200 --seed 3 --params persistence,sigma-scale --force-overwrite";

TEST(LaplaceIsCli, MediansInsideTmcmcIntervalsAndTheSameOnOneAndTwoThreads) {
  const fs::path dir = rbc::testing::fresh_output_dir("laplace_is_cli");
  const std::string data = " --data-file " + small_data(dir).string();
  const auto tm =
      run_rbc("infer" + kCommon + data + " --sampler tmcmc --samples 200 --chain-length 2 --out " +
                  (dir / "tmcmc").string(),
              2);
  ASSERT_EQ(tm.exit_code, 0) << tm.all();
  const auto is1 = run_rbc("infer --sampler laplace-is --is-samples 300" + kCommon + data +
                               " --out " + (dir / "is1").string(),
                           1);
  ASSERT_EQ(is1.exit_code, 0) << is1.all();
  const auto is2 = run_rbc("infer --sampler laplace-is --is-samples 300" + kCommon + data +
                               " --out " + (dir / "is2").string(),
                           2);
  ASSERT_EQ(is2.exit_code, 0) << is2.all();
  const std::string samples = read(dir / "is1" / "posterior_samples.csv");
  ASSERT_FALSE(samples.empty());
  EXPECT_EQ(samples, read(dir / "is2" / "posterior_samples.csv"));
  EXPECT_EQ(without_timing(dir / "is1" / "summary.json"),
            without_timing(dir / "is2" / "summary.json"));

  const auto t = nlohmann::json::parse(read(dir / "tmcmc" / "summary.json"));
  const auto l = nlohmann::json::parse(read(dir / "is1" / "summary.json"));
  EXPECT_EQ(t["sampler"], "tmcmc");
  EXPECT_EQ(l["sampler"], "laplace-is");
  EXPECT_GT(l["ess"].get<double>(), 30.0);
  EXPECT_LE(l["ess"].get<double>(), 300.0);
  EXPECT_TRUE(fs::exists(dir / "is1" / "checkpoint.h5"));  // laplace-is checkpoints too
  for (const char* p : {"persistence", "sigma-scale"}) {
    const double median = l["parameters"][p]["q50"];
    EXPECT_GT(median, t["parameters"][p]["q05"].get<double>()) << p;
    EXPECT_LT(median, t["parameters"][p]["q95"].get<double>()) << p;
  }
  const double mu = l["derived"]["mu"]["q50"];
  EXPECT_GT(mu, t["derived"]["mu"]["q05"].get<double>());
  EXPECT_LT(mu, t["derived"]["mu"]["q95"].get<double>());
  // The evidences agree within 4 combined standard errors (plus 0.1 for TMCMC's bias at 200
  // samples per stage).
  const double dz = l["log_evidence"].get<double>() - t["log_evidence"].get<double>();
  const double se =
      std::hypot(l["log_evidence_sd"].get<double>(), t["log_evidence_sd"].get<double>());
  EXPECT_LT(std::abs(dz), 4 * se + 0.1) << dz << " +- " << se;
}

TEST(LaplaceIsCli, RefusesWhatItCannotTakeBeforeAnyWork) {
  const fs::path dir = rbc::testing::fresh_output_dir("laplace_is_cli_bad");
  const std::string data = " --data-file " + small_data(dir).string();
  struct Case {
    std::string args, expect;
  };
  for (const Case& c : std::vector<Case>{
           {"--sampler laplace-is --is-samples 5",
            "rbc: error: --is-samples 5: expected at least 10"},
           {"--sampler hmc", "--sampler"},
           {"--sampler laplace-is --min-ess -1",
            "rbc: error: --min-ess -1: expected a finite number >= 0"},
           {"--sampler tmcmc --min-ess 10",
            "rbc: error: --min-ess 10: a setting of the laplace-is sampler"},
           {"--sampler laplace-is --resume " + dir.string(), "rbc: error: --resume"},
       }) {
    const fs::path out = dir / "out";
    const auto r =
        run_rbc("infer " + c.args + data +
                    (c.args.find("--resume") == std::string::npos ? " --out " + out.string()
                                                                  : std::string()),
                1);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.all();
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out / "summary.json")) << c.args;
  }
}

// Importance weights that leave fewer effective samples than --min-ess stop the run with status
// low_ess and exit 1, naming the count, and write no posterior; a lower floor accepts the same
// draws.
TEST(LaplaceIsCli, TooFewEffectiveSamplesStopTheRunWithExitOne) {
  const fs::path dir = rbc::testing::fresh_output_dir("laplace_is_cli_low_ess");
  const std::string args = "infer --sampler laplace-is --is-samples 20" + kCommon +
                           " --data-file " + small_data(dir).string() + " --out ";
  const auto low = run_rbc(args + (dir / "low").string(), 1);
  EXPECT_EQ(low.exit_code, 1) << low.all();
  EXPECT_EQ(low.err.rfind("rbc: error: inference stopped (low_ess): laplace-is kept ", 0), 0u)
      << low.err;
  EXPECT_NE(low.err.find(" effective samples of 20 (at least 50)"), std::string::npos) << low.err;
  EXPECT_FALSE(fs::exists(dir / "low" / "summary.json"));
  const auto accepted = run_rbc(args + (dir / "accepted").string() + " --min-ess 2", 1);
  ASSERT_EQ(accepted.exit_code, 0) << accepted.all();
  const auto j = nlohmann::json::parse(std::ifstream(dir / "accepted" / "summary.json"));
  EXPECT_GE(j["ess"].get<double>(), 2.0);
  EXPECT_LT(j["ess"].get<double>(), 20.0 + 1e-9);
}

}  // namespace
