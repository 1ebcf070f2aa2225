// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer --sampler laplace-is --resume DIR`: a run stopped by SIGTERM during the mode search
// or killed with SIGKILL during the importance draws (1 or 2 OpenMP threads) resumes from its
// last checkpoint, on the other thread count, to the result of a straight run, number for
// number: samples, summary (timing and command line aside), predictive band, marginals. A
// resume with changed inputs, or of the other sampler's checkpoint, is refused with exit 2,
// one line and nothing written.
//
// The problem: continuum p = 2 on 200 elements, three forces, two parameters, 40 importance
// samples (four blocks of 10 draws, a checkpoint after each). Under mpirun (when there is one)
// the blocks go through the MPI master-worker executor to the same result.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "cli_run.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"
#include "infer_resume_helpers.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

using namespace testing::infer_resume;

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kIsSamples = 40;

std::vector<std::string> problem_args(const std::string& data, const std::string& seed = "3",
                                      const std::string& is_samples = "40") {
  return {"infer", "--sampler", "laplace-is", "--is-samples", is_samples,
          // 40 draws of this problem keep about 18 effective samples: enough to compare runs
          // bit for bit, below the default floor of an accepted posterior.
          "--min-ess", "5", "--method", "continuum:2:200", "--seed", seed, "--params",
          "persistence,sigma-scale", "--data-file", data};
}

/// Where a checkpoint's run is.
struct Position {
  long long mode_found = -1, newton_steps = -1, draws_done = -1;
  std::string sampler;
};
Position position(const fs::path& dir) {
  const H5File h = H5File::open_read((dir / "checkpoint.h5").string());
  Position p;
  p.sampler = h.read_attribute_string("sampler");
  p.mode_found = h.read_attribute_int("mode_found");
  p.newton_steps = h.read_attribute_int("newton_steps");
  p.draws_done = h.read_attribute_int("draws_done");
  return p;
}

TEST(LaplaceIsResume, StoppedOrKilledRunsResumeToTheStraightResultOnAnotherThreadCount) {
  const fs::path dir = testing::fresh_output_dir("laplace_is_resume");
  const auto args = problem_args(data_file(dir));
  const fs::path straight = dir / "straight";
  const testing::CliRun s = testing::run_rbc(joined(args) + " -q --out " + straight.string(), 1);
  ASSERT_EQ(s.exit_code, 0) << s.all();
  {  // the last checkpoint holds every draw
    const Position p = position(straight);
    EXPECT_EQ(p.sampler, "laplace-is");
    EXPECT_EQ(p.mode_found, 1);
    EXPECT_EQ(p.draws_done, kIsSamples);
    const json j = json::parse(read_text(straight / "summary.json"));
    EXPECT_EQ(p.newton_steps, j["laplace"]["newton_steps"].get<long long>());
    ASSERT_GE(p.newton_steps, 2) << "the mode search must have steps to stop in";
  }

  struct Case {
    std::string name, marker;
    int signal, threads, resume_threads;
    bool in_mode_search;  ///< where the checkpoint resumed from must be
  };
  for (const Case& c :
       {Case{"term_mode_t1", "gradient evaluation 2:", SIGTERM, 1, 2, true},
        Case{"kill_draws_t2", "importance sampling, 10 of 40", SIGKILL, 2, 1, false},
        Case{"term_draws_t1", "importance sampling, 20 of 40", SIGTERM, 1, 2, false}}) {
    SCOPED_TRACE(c.name);
    const fs::path out = dir / c.name;
    const Interrupted k = interrupt_run(args, out, c.marker, c.signal, c.threads);
    ASSERT_NE(k.exit_code, -1000) << "'" << c.marker << "' never reported: " << k.log;
    if (k.mid_run) {
      EXPECT_EQ(k.exit_code, c.signal == SIGKILL ? -SIGKILL : 143) << k.log;
      if (c.signal == SIGTERM) {
        EXPECT_NE(k.log.find("rbc: SIGTERM received: stopping; the last checkpoint ("),
                  std::string::npos)
            << k.log;
        EXPECT_NE(k.log.find("continue with --resume " + out.string()), std::string::npos) << k.log;
      }
      EXPECT_FALSE(fs::exists(out / "summary.json"));
    } else {
      std::cerr << "note: " << c.name << " finished before the signal; resuming from the "
                << "checkpoint of '" << c.marker << "'\n";
    }
    const Position from = position(out);
    if (c.in_mode_search) {
      EXPECT_EQ(from.mode_found, 0) << "the checkpoint is past the mode search";
    } else {
      EXPECT_EQ(from.mode_found, 1);
      EXPECT_GE(from.draws_done, 10);
      EXPECT_LT(from.draws_done, kIsSamples) << "the checkpoint holds every draw";
    }
    std::ofstream(out / ".checkpoint.h5.partial-999999") << "cut short";
    const testing::CliRun r =
        testing::run_rbc(joined(args) + " --resume " + out.string(), c.resume_threads);
    ASSERT_EQ(r.exit_code, 0) << r.all();
    EXPECT_NE(r.err.find("laplace-is: resuming from the checkpoint ("), std::string::npos) << r.err;
    expect_same_posterior(straight, out);
    EXPECT_EQ(json::parse(read_text(out / "summary.json"))["timing"]["threads"], c.resume_threads);
    for (const auto& e : fs::directory_iterator(out))
      EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
  }
}

TEST(LaplaceIsResume, MpiRunsAndAResumeUnderMpiGiveTheSingleProcessResult) {
  const std::string mpirun = RBC_MPIRUN;
  if (mpirun.empty()) GTEST_SKIP() << "mpirun not found";
  const fs::path dir = testing::fresh_output_dir("laplace_is_resume_mpi");
  const auto args = problem_args(data_file(dir));
  const std::string np2 = mpirun +
                          " --allow-run-as-root --oversubscribe -np 2 -x OMP_NUM_THREADS -x "
                          "OMP_WAIT_POLICY " +
                          std::string(RBC_BINARY_DIR) + "/rbc ";
  const fs::path straight = dir / "straight";
  const testing::CliRun s = testing::run_rbc(joined(args) + " -q --out " + straight.string(), 1);
  ASSERT_EQ(s.exit_code, 0) << s.all();
  // The blocks of draws through the MPI master-worker executor.
  const fs::path mpi = dir / "mpi";
  const testing::CliRun m = shell(np2 + joined(args) + " -q --out " + mpi.string());
  ASSERT_EQ(m.exit_code, 0) << m.all();
  expect_same_posterior(straight, mpi);
  // A single-process run killed among the draws, resumed on two ranks.
  const fs::path out = dir / "killed";
  const Interrupted k = interrupt_run(args, out, "importance sampling, 10 of 40", SIGKILL, 1);
  ASSERT_NE(k.exit_code, -1000) << k.log;
  const Position from = position(out);
  EXPECT_EQ(from.mode_found, 1);
  EXPECT_LT(from.draws_done, kIsSamples);
  const testing::CliRun r = shell(np2 + joined(args) + " --resume " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.all();
  expect_same_posterior(straight, out);
}

/// Exit 2, one "rbc: error:" line naming every string of `expect`, no work started and nothing
/// new or changed in the directory.
void expect_refused(const std::string& args, const std::vector<std::string>& expect,
                    const fs::path& dir) {
  SCOPED_TRACE(args);
  std::vector<std::pair<std::string, std::string>> before;
  for (const auto& e : fs::directory_iterator(dir))
    before.emplace_back(e.path().filename(), read_text(e.path()));
  const testing::CliRun r = testing::run_rbc(args, 1);
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_EQ(r.err.rfind("rbc: error: ", 0), 0u) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
  for (const std::string& x : expect) EXPECT_NE(r.err.find(x), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("gradient evaluation"), std::string::npos) << "work started: " << r.err;
  EXPECT_EQ(r.err.find("beta ="), std::string::npos) << "work started: " << r.err;
  std::vector<std::pair<std::string, std::string>> after;
  for (const auto& e : fs::directory_iterator(dir))
    after.emplace_back(e.path().filename(), read_text(e.path()));
  std::sort(before.begin(), before.end());
  std::sort(after.begin(), after.end());
  EXPECT_TRUE(before == after) << "the directory changed";
}

TEST(LaplaceIsResume, ChangedInputsAndTheOtherSamplersCheckpointsAreRefusedBeforeWork) {
  const fs::path dir = testing::fresh_output_dir("laplace_is_resume_refusals");
  const std::string data = data_file(dir);
  const fs::path run = dir / "run";
  const auto args = problem_args(data);
  const testing::CliRun s = testing::run_rbc(joined(args) + " -q --out " + run.string(), 1);
  ASSERT_EQ(s.exit_code, 0) << s.all();

  expect_refused(joined(problem_args(data, "3", "80")) + " --resume " + run.string(),
                 {"--is-samples (checkpoint 40, this run 80)"}, run);
  expect_refused(joined(problem_args(data, "4")) + " --resume " + run.string(),
                 {"--seed (checkpoint 3, this run 4)"}, run);
  {
    const fs::path data2 = dir / "other.csv";
    std::ofstream(data2) << read_text(data) << "120,14.5,1.2,4.3,0.6\n";
    expect_refused(joined(problem_args(data2.string())) + " --resume " + run.string(),
                   {"--data-file contents"}, run);
    std::vector<std::string> method = args;
    method[std::find(method.begin(), method.end(), std::string("--method")) - method.begin() + 1] =
        "continuum:2:300";
    expect_refused(joined(method) + " --resume " + run.string(), {"--method"}, run);
  }
  // The laplace-is checkpoint resumed by TMCMC.
  const std::string tmcmc_args =
      "infer --sampler tmcmc --samples 20 --chain-length 1 --seed 3 --method "
      "continuum:2:200 --params persistence,sigma-scale --data-file " +
      data;
  expect_refused(tmcmc_args + " --resume " + run.string(),
                 {"--sampler laplace-is", "--sampler tmcmc"}, run);
  // A TMCMC checkpoint resumed by laplace-is.
  const fs::path tmcmc = dir / "tmcmc";
  const testing::CliRun t = testing::run_rbc(tmcmc_args + " -q --out " + tmcmc.string(), 1);
  ASSERT_EQ(t.exit_code, 0) << t.all();
  expect_refused(joined(args) + " --resume " + tmcmc.string(),
                 {"--sampler tmcmc", "--sampler laplace-is"}, tmcmc);
  // A new laplace-is run into a directory holding a checkpoint names --resume.
  expect_refused(joined(args) + " --out " + run.string(), {"--resume " + run.string()}, run);
  // A corrupt laplace-is checkpoint: one byte of the mode's warm state changed.
  {
    const fs::path bad = dir / "corrupt";
    fs::create_directories(bad);
    fs::copy_file(run / "checkpoint.h5", bad / "checkpoint.h5");
    ASSERT_TRUE(flip_dataset_byte(bad / "checkpoint.h5", "/mode/state"));
    expect_refused(joined(args) + " --resume " + bad.string(), {"checkpoint.h5"}, bad);
  }
}

}  // namespace
}  // namespace rbc
