// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer` from the command line: bad input exits 2 naming the value before any forward
// run and leaves nothing behind; the posterior samples depend on the seed only (1 and 2
// threads, 1 and 3 MPI ranks).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace {
namespace fs = std::filesystem;

struct CommandRun {
  int exit_code;
  std::string output;
};

CommandRun run(const std::string& cmd) {
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  std::string out;
  std::array<char, 512> buf{};
  while (fgets(buf.data(), buf.size(), p)) out += buf.data();
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

const std::string kRbc = std::string(RBC_BINARY_DIR) + "/rbc";
const std::string kDir = std::string(RBC_BINARY_DIR) + "/test_output/calibrate_cli";

std::string write_file(const std::string& name, const std::string& text) {
  fs::create_directories(kDir);
  const std::string path = kDir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

const char* kHeader = "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n";

TEST(InferCli, BadInputExitsTwoNamingTheValueAndWritesNothing) {
  struct Case {
    std::string args, expect;
  };
  const std::string good = "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n";
  const std::vector<Case> cases = {
      {"--data-file " + write_file("missing_column.csv",
                                   "force_pN,axial_um,axial_err_um,transverse_um\n0,1,1,1\n"),
       "transverse_err_um"},
      {"--data-file " +
           write_file("non_numeric.csv", std::string(kHeader) + good + "40,11,0.9,x5.1,0.6\n"),
       "x5.1"},
      {"--data-file " +
           write_file("zero_error.csv", std::string(kHeader) + good + "40,11,0,5.1,0.6\n"),
       "axial_err_um 0"},
      {"--data-file " +
           write_file("decreasing.csv", std::string(kHeader) + good + "20,11,0.9,5.1,0.6\n"),
       "force_pN 20"},
      {"--data-file /nonexistent/rbc_mills.csv", "rbc_mills.csv"},
      // A row beyond the chosen model's documented maximum: refused naming file, row and force.
      {"--method continuum:2:200 --data-file " +
           write_file("beyond.csv", std::string(kHeader) + good + "1000,20,0.9,4,0.6\n"),
       "beyond.csv' data row 3: force (continuum model) must be finite and in [0, 400] pN, got "
       "1000 pN"},
      {"--method discrete:300 --data-file " +
           write_file("beyond_discrete.csv", std::string(kHeader) + good + "600,20,0.9,4,0.6\n"),
       "data row 3: force (discrete model) must be finite and in [0, 500] pN, got 600 pN"},
      {"--data-file " + kDir, "is a directory, expected a CSV file"},
      {"--prior persistence=20:3", "persistence=20:3"},
      {"--prior persistence=3:3", "persistence=3:3"},
      {"--prior lmax=abc:300", "abc"},
      {"--params persistence,stiffness", "stiffness"},
      {"--params persistence --prior kappa=1e-19:3e-19", "kappa"},
      {"--method continuum:7:200", "7"},
      {"--sampler tmcmc --samples 2", "samples"},
      // The sampler's floor, named as the option (4 islands of at least 5 samples).
      {"--sampler tmcmc --samples 10",
       "rbc: error: --samples 10: expected at least 20 samples per stage"},
      // Each sampler's settings with the other sampler (laplace-is is the default).
      {"--samples 30",
       "rbc: error: --samples 30: a setting of the tmcmc sampler, not of laplace-is; expected "
       "--sampler tmcmc with it"},
      {"--sampler laplace-is --chain-length 2", "--chain-length 2: a setting of the tmcmc sampler"},
      {"--sampler tmcmc --is-samples 300",
       "--is-samples 300: a setting of the laplace-is sampler, not of tmcmc"},
      {"--sampler tmcmc --is-rounds 2",
       "--is-rounds 2: a setting of the laplace-is sampler, not of tmcmc"},
      {"--is-rounds 0", "--is-rounds 0: expected 1 to --is-samples (1000)"},
      {"--is-samples 100 --is-rounds 101", "--is-rounds 101: expected 1 to --is-samples (100)"},
      {"--sampler nuts", "--sampler"},
      {"--extra-uncertainty -1", "--extra-uncertainty must be finite and >= 0 um, got -1"},
      // The model option group: a parameter not inferred takes its value; an inferred one and
      // physics the forward model keeps fixed are refused, not ignored.
      {"--persistence 10", "rbc: error: --persistence 10: persistence is inferred (--params)"},
      {"--params lmax,sigma-scale --persistence -3", "--persistence -3: expected"},
      {"--lbar 80",
       "--lbar 80: rbc infer's forward model keeps the paper's value; expected the default 75"},
      {"--bending dihedral", "--bending dihedral: rbc infer's forward model keeps"},
      {"--data-file " +
           write_file("misspelt.csv", "# extra_uncertainty: 0.2\n" + std::string(kHeader) + good),
       "'extra_uncertainty', which is not a declaration"},
  };
  for (const auto& c : cases) {
    const std::string out = kDir + "/never";
    fs::remove_all(out);
    const CommandRun r = run(kRbc + " infer --out " + out + " " + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find("rbc: error:"), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_EQ(r.output.find("beta ="), std::string::npos) << "work started: " << r.output;
    EXPECT_TRUE(!fs::exists(out) || fs::is_empty(out)) << c.args;
  }
}

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

nlohmann::json without_timing(const std::string& path) {
  nlohmann::json j = nlohmann::json::parse(read(path));
  j.erase("timing");
  j.erase("command");     // names the --out directory
  j.erase("provenance");  // date, threads, command line
  if (j.contains("config")) j["config"].erase("out");
  return j;
}

// Determinism (acceptance item): a small, cheap problem (continuum p = 2 on 200 elements,
// three forces, 20 samples per stage, one Metropolis step, two parameters) run with 1 and 2 OpenMP
// threads and under mpirun with 1 and 3 ranks gives byte-identical posterior samples and summaries
// (apart from timing).
TEST(InferCli, PosteriorDependsOnTheSeedOnlyNotOnThreadsOrRanks) {
  const std::string data =
      write_file("small.csv", std::string(kHeader) +
                                  "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n90,13.8,1.2,4.6,0.6\n");
  const std::string common =
      " infer -q --method continuum:2:200 --sampler tmcmc --samples 20 --chain-length 1 --seed 3 "
      "--params persistence,sigma-scale --force-overwrite --data-file " +
      data + " --out ";
  auto go = [&](const std::string& launcher, const std::string& name) {
    const std::string out = kDir + "/det_" + name;
    fs::remove_all(out);
    const CommandRun r = run("OMP_WAIT_POLICY=passive " + launcher + kRbc + common + out);
    EXPECT_EQ(r.exit_code, 0) << launcher << "\n" << r.output;
    return out;
  };
  const std::string t1 = go("OMP_NUM_THREADS=1 ", "t1");
  const std::string t2 = go("OMP_NUM_THREADS=2 ", "t2");
  const std::string samples = read(t1 + "/posterior_samples.csv");
  ASSERT_FALSE(samples.empty());
  EXPECT_EQ(samples, read(t2 + "/posterior_samples.csv"));
  EXPECT_EQ(without_timing(t1 + "/summary.json"), without_timing(t2 + "/summary.json"));
  // The two runs really used 1 and 2 threads (OpenBLAS's OpenMP build once reset OpenMP's
  // count to 1 for the whole inference).
  EXPECT_EQ(nlohmann::json::parse(read(t1 + "/summary.json"))["timing"]["threads"], 1);
  EXPECT_EQ(nlohmann::json::parse(read(t2 + "/summary.json"))["timing"]["threads"], 2);
  const std::string mpirun = RBC_MPIRUN;
  if (mpirun.empty()) GTEST_SKIP() << "mpirun not found";
  for (int np : {1, 3}) {
    const std::string m =
        go("OMP_NUM_THREADS=1 " + mpirun + " --allow-run-as-root --oversubscribe -np " +
               std::to_string(np) + " -x OMP_WAIT_POLICY -x OMP_NUM_THREADS ",
           "mpi" + std::to_string(np));
    EXPECT_EQ(samples, read(m + "/posterior_samples.csv")) << np << " ranks";
    EXPECT_EQ(without_timing(t1 + "/summary.json"), without_timing(m + "/summary.json"));
  }
}

TEST(InferCli, WritesTheDocumentedOutputs) {
  const std::string data =
      write_file("outputs.csv", std::string(kHeader) + "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n");
  const std::string out = kDir + "/outputs";
  fs::remove_all(out);
  const CommandRun r = run("OMP_NUM_THREADS=2 " + kRbc +
                           " infer --method continuum:2:200 --sampler tmcmc --samples 20 --params "
                           "persistence "
                           "--json --data-file " +
                           data + " --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* f : {"summary.json", "posterior_samples.csv", "posterior_samples.h5",
                        "corner.png", "predictive.png", "predictive.csv"})
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  const auto j = nlohmann::json::parse(read(out + "/summary.json"));
  for (const char* k : {"mean", "sd", "q05", "q50", "q95"}) {
    EXPECT_TRUE(j["parameters"]["persistence"].contains(k)) << k;
    EXPECT_TRUE(j["derived"]["mu"].contains(k)) << k;
    EXPECT_TRUE(j["derived"]["K"].contains(k)) << k;
  }
  EXPECT_TRUE(j.contains("log_evidence") && j.contains("log_evidence_sd"));
  EXPECT_GT(j["forward_runs"]["made"].get<long long>(), 20);
  EXPECT_NE(r.output.find("stage 1"), std::string::npos) << "progress on stderr";
  // Progress is on stderr, the JSON on stdout: the JSON parses from the last '{' block.
  EXPECT_NE(r.output.find("\"log_evidence\""), std::string::npos);
}

TEST(InferCli, HelpNamesTheSmallestSampleCount) {
  const CommandRun r = run(kRbc + " infer --help");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("tmcmc: samples per stage, at least 20"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--extra-uncertainty"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("--reading-uncertainty"), std::string::npos) << r.output;
}

/// A tiny inference on `data` (sigma-scale only: every forward run is the same cheap sweep).
CommandRun tiny_inference(const std::string& data, const std::string& out,
                          const std::string& extra_args = "") {
  fs::remove_all(out);
  return run("OMP_NUM_THREADS=1 " + kRbc +
             " infer --method continuum:2:200 --sampler tmcmc --samples 20 --chain-length 1 "
             "--params sigma-scale "
             "--data-file " +
             data + " --out " + out + " " + extra_args);
}

// A user's file without declarations: the likelihood used its error bars exactly (summary.json's
// data), nothing was added, and the plots and the printed summary name the data by the file's
// name.
TEST(InferCli, AUsersFileGetsExactlyItsOwnErrorBarsAndIsLabelledByItsFileName) {
  const std::string data =
      write_file("own_cells.csv", std::string(kHeader) +
                                      "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n"
                                      "90,13.8,1.2,4.6,0.55\n");
  const std::string out = kDir + "/own_sigma";
  const CommandRun r = tiny_inference(data, out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(read(out + "/summary.json"));
  const double axial_err[] = {0.7, 0.9, 1.2}, transverse_err[] = {0.7, 0.6, 0.55};
  ASSERT_EQ(j["data"].size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(j["data"][k]["axial_sigma_um"].get<double>(), axial_err[k]) << k;
    EXPECT_EQ(j["data"][k]["transverse_sigma_um"].get<double>(), transverse_err[k]) << k;
  }
  ASSERT_EQ(j["data_sets"].size(), 1u);
  const auto& set = j["data_sets"][0];
  EXPECT_EQ(set["name"], "own_cells.csv");
  EXPECT_EQ(set["declared_extra_uncertainty_um"].get<double>(), 0.0);
  EXPECT_EQ(set["added_extra_uncertainty_um"].get<double>(), 0.0);
  EXPECT_EQ(set["sigma"], "the file's error bars");
  EXPECT_NE(r.output.find("sigma: the file's error bars\n"), std::string::npos) << r.output;
  const std::string gp = read(out + "/predictive.gp");
  EXPECT_NE(gp.find("D_{A} own\\_cells.csv (error bar)"), std::string::npos) << gp;
  EXPECT_EQ(gp.find("Mills"), std::string::npos) << gp;
}

// A declared name labels the data in the plot, the summary and summary.json; a declared extra
// uncertainty and --extra-uncertainty add in quadrature with each error bar.
TEST(InferCli, DeclaredNameAndUncertaintyReachTheLikelihoodThePlotAndTheSummary) {
  const std::string data = write_file(
      "declared.csv", "# name: Lab B healthy donors\n# extra_uncertainty_um: 0.3\n" +
                          std::string(kHeader) + "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n");
  const std::string out = kDir + "/declared_sigma";
  const CommandRun r = tiny_inference(data, out, "--extra-uncertainty 0.4");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(read(out + "/summary.json"));
  EXPECT_NEAR(j["data"][1]["axial_sigma_um"].get<double>(), std::sqrt(0.81 + 0.09 + 0.16), 1e-15);
  EXPECT_NEAR(j["data"][1]["transverse_sigma_um"].get<double>(), std::sqrt(0.36 + 0.25), 1e-15);
  const auto& set = j["data_sets"][0];
  EXPECT_EQ(set["name"], "Lab B healthy donors");
  EXPECT_EQ(set["declared_extra_uncertainty_um"].get<double>(), 0.3);
  EXPECT_EQ(set["added_extra_uncertainty_um"].get<double>(), 0.4);
  EXPECT_NEAR(set["extra_uncertainty_um"].get<double>(), 0.5, 1e-15);
  EXPECT_NE(r.output.find("data: Lab B healthy donors (" + data + ")"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("sigma: the file's error bars (+) 0.3 um declared (+) 0.4 um added"),
            std::string::npos)
      << r.output;
  const std::string gp = read(out + "/predictive.gp");
  EXPECT_NE(gp.find("D_{A} Lab B healthy donors (error bar ⊕ 0.5 µm)"), std::string::npos) << gp;
  EXPECT_NE(gp.find("D_{T} Lab B healthy donors (error bar ⊕ 0.5 µm)"), std::string::npos) << gp;
}

// --config DIR/run.json repeats a run: the same posterior, bit for bit. The run record (resolved
// options, provenance) is in run.json and summary.json; a fixed parameter of the model option
// group (--persistence, not inferred here) travels with it.
TEST(InferCli, ConfigOfARunRepeatsItsPosterior) {
  const std::string data =
      write_file("config.csv", std::string(kHeader) + "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n");
  const std::string first = kDir + "/config_first", again = kDir + "/config_again";
  const CommandRun r =
      tiny_inference(data, first, "--persistence 12 --extra-uncertainty 0.2 --seed 7");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto run_json = nlohmann::json::parse(read(first + "/run.json"));
  EXPECT_EQ(run_json["command"], "infer");
  EXPECT_EQ(run_json["config"]["persistence"].get<double>(), 12.0);
  // --extra-uncertainty takes UM or STEM=UM, so the config records the text as given.
  EXPECT_EQ(run_json["config"]["extra-uncertainty"], "0.2");
  EXPECT_EQ(run_json["config"]["samples"].get<int>(), 20);
  EXPECT_TRUE(run_json["provenance"].contains("rbc_version"));
  EXPECT_EQ(run_json["status"], "converged");
  const auto summary = nlohmann::json::parse(read(first + "/summary.json"));
  EXPECT_EQ(summary["config"], run_json["config"]);
  EXPECT_TRUE(summary["provenance"].contains("command_line"));

  fs::remove_all(again);
  const CommandRun b =
      run("OMP_NUM_THREADS=2 " + kRbc + " infer -q --config " + first + "/run.json --out " + again);
  ASSERT_EQ(b.exit_code, 0) << b.output;
  const std::string samples = read(first + "/posterior_samples.csv");
  ASSERT_FALSE(samples.empty());
  EXPECT_EQ(samples, read(again + "/posterior_samples.csv"));
  auto posterior = [](const std::string& dir) {
    nlohmann::json j = without_timing(dir + "/summary.json");
    j["config"].erase("quiet");
    return j;
  };
  EXPECT_EQ(posterior(first), posterior(again));
}

// The printed summary counts the stages the progress log shows: stage 0 (the prior) and the
// tempering stages 1..N, N = summary.json's "stages".
TEST(InferCli, ThePrintedStageCountAgreesWithTheProgressLog) {
  const std::string data =
      write_file("stages.csv", std::string(kHeader) + "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n");
  const std::string out = kDir + "/stages";
  const CommandRun r = tiny_inference(data, out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const int n = nlohmann::json::parse(read(out + "/summary.json"))["stages"].get<int>();
  ASSERT_GE(n, 1);
  EXPECT_NE(r.output.find("] stage 0 (prior): beta = 0,"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("] stage " + std::to_string(n) + ": beta = 1,"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("] stage " + std::to_string(n + 1) + ":"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("stage 0 (prior) and " + std::to_string(n) + " tempering stage"),
            std::string::npos)
      << r.output;
}

}  // namespace

// The report's calibration section is read from cached `rbc infer --out` results: two small
// real runs (continuum p = 2 and the full law on 200 elements) make a cache; the section must
// print each run's mu interval as its summary.json has it, copy the predictive plot and
// compare the two runs; a missing cache, a corrupt index and a truncated summary must each
// exit 2 naming the file, before anything is written.
TEST(ReportCli, CalibrationSectionReadsTheCacheAndRefusesABadOne) {
  const std::string data =
      write_file("report.csv", std::string(kHeader) +
                                   "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n90,13.8,1.2,4.6,0.6\n");
  const std::string cache = kDir + "/cache";
  fs::remove_all(cache);
  for (const char* m : {"continuum:2:200", "continuum:full:200"}) {
    const std::string name = std::string(m).find("full") != std::string::npos ? "full" : "p2";
    const CommandRun r = run("OMP_WAIT_POLICY=passive OMP_NUM_THREADS=1 " + kRbc +
                             " infer -q --sampler tmcmc --samples 20 --chain-length 1 --seed 3 "
                             "--params "
                             "persistence,sigma-scale --method " +
                             m + " --data-file " + data + " --out " + cache + "/" + name);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  std::ofstream(cache + "/index.json")
      << R"({"readings": [{"dir": "p2", "label": "small test data"}],
             "comparison": {"reference": "p2", "others": ["full"]}})";
  const std::string out = kDir + "/report";
  fs::remove_all(out);
  const CommandRun ok =
      run(kRbc + " report --calibration-only --calibration " + cache + " --out " + out);
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  const std::string md = read(out + "/report.md");
  EXPECT_NE(md.find("## Calibration"), std::string::npos);
  EXPECT_NE(md.find("small test data"), std::string::npos);
  EXPECT_NE(md.find("Posterior-predictive check"), std::string::npos);
  EXPECT_NE(md.find("Model comparison"), std::string::npos);
  EXPECT_NE(md.find("continuum_pfull_E200"), std::string::npos) << md;
  EXPECT_TRUE(fs::is_regular_file(out + "/calibration/p2/predictive.png"));
  const nlohmann::json s = nlohmann::json::parse(read(cache + "/p2/summary.json"));
  std::ostringstream mu;
  mu << std::setprecision(3) << s["derived"]["mu"]["q50"].get<double>() << " ["
     << s["derived"]["mu"]["q05"].get<double>() << ", " << s["derived"]["mu"]["q95"].get<double>()
     << "]";
  EXPECT_NE(md.find(mu.str()), std::string::npos) << mu.str() << "\n" << md;

  auto refused = [&](const std::string& dir, const std::string& expect) {
    const std::string never = kDir + "/report_never";
    fs::remove_all(never);
    const CommandRun r =
        run(kRbc + " report --calibration-only --calibration " + dir + " --out " + never);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("rbc: error: calibration cache"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(expect), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(never));
  };
  refused(kDir + "/no_such_cache", "index.json");
  const std::string bad = kDir + "/cache_bad";
  fs::remove_all(bad);
  fs::create_directories(bad);
  fs::copy(cache + "/p2", bad + "/p2");
  std::ofstream(bad + "/index.json") << R"({"readings": [{"dir": "p2"})";  // truncated
  refused(bad, "index.json");
  std::ofstream(bad + "/index.json") << R"({"readings": [{"dir": "p2"}]})";
  const std::string summary = read(bad + "/p2/summary.json");
  std::ofstream(bad + "/p2/summary.json") << summary.substr(0, summary.size() / 2);
  refused(bad, "summary.json");
  fs::remove(bad + "/p2/summary.json");
  refused(bad, "summary.json");
}
