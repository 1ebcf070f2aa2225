// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer --resume DIR`: a run killed with SIGKILL during a stage (1 or 2 OpenMP threads, or
// one rank of `mpirun -np 2`) or stopped by SIGTERM resumes from its last complete stage to the
// posterior of a straight run, number for number: samples, summary (timing and command line
// aside), predictive band, marginals. A resume is refused with exit 2, one line and nothing
// written when the checkpoint is missing, corrupt or of other inputs; seeds outside
// [0, 2^64 - 1] are refused.
//
// The problem: continuum p = 2 on 200 elements, three forces, two parameters, 40 samples,
// two Metropolis steps, target coefficient of variation 0.5: five stages of ~0.1-0.5 s each, so
// a kill after stage 1 or 2 lands inside a later stage.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
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

const std::string kRbc = std::string(RBC_BINARY_DIR) + "/rbc";
const std::string kMpirun = RBC_MPIRUN;

std::vector<std::string> problem_args(const std::string& data, const std::string& seed = "3") {
  return {"infer",
          "--method",
          "continuum:2:200",
          "--sampler",
          "tmcmc",
          "--samples",
          "40",
          "--chain-length",
          "2",
          "--target-cov",
          "0.5",
          "--seed",
          seed,
          "--params",
          "persistence,sigma-scale",
          "--data-file",
          data};
}

long long checkpoint_stage(const fs::path& dir) {
  return H5File::open_read((dir / "checkpoint.h5").string()).read_attribute_int("stage");
}

testing::CliRun resume(const std::vector<std::string>& args, const fs::path& dir, int threads) {
  return testing::run_rbc(joined(args) + " --resume " + dir.string(), threads);
}

TEST(InferResume, KilledOrInterruptedRunsResumeToTheStraightPosteriorOnOneAndTwoThreads) {
  const fs::path dir = testing::fresh_output_dir("infer_resume_threads");
  const auto args = problem_args(data_file(dir));
  const fs::path straight = dir / "straight";
  const testing::CliRun s = testing::run_rbc(joined(args) + " -q --out " + straight.string(), 1);
  ASSERT_EQ(s.exit_code, 0) << s.all();
  const long long stages = json::parse(read_text(straight / "summary.json"))["stages"];
  ASSERT_GE(stages, 4) << "the problem must have stages to kill in";
  EXPECT_EQ(checkpoint_stage(straight), stages);  // the last checkpoint is of the last stage

  struct Case {
    std::string name;
    int signal, after, threads, resume_threads;
  };
  for (const Case& c : {Case{"kill_t1", SIGKILL, 2, 1, 2}, Case{"kill_t2", SIGKILL, 1, 2, 1},
                        Case{"term_t1", SIGTERM, 1, 1, 1}}) {
    SCOPED_TRACE(c.name);
    const fs::path out = dir / c.name;
    const Interrupted k =
        interrupt_run(args, out, "stage " + std::to_string(c.after) + ":", c.signal, c.threads);
    ASSERT_NE(k.exit_code, -1000) << "stage " << c.after << " never reported: " << k.log;
    if (k.mid_run) {
      EXPECT_EQ(k.exit_code, c.signal == SIGKILL ? -SIGKILL : 143) << k.log;
      if (c.signal == SIGTERM) {
        EXPECT_NE(k.log.find("rbc: interrupted by SIGTERM"), std::string::npos) << k.log;
        EXPECT_NE(k.log.find("continue with --resume " + out.string()), std::string::npos) << k.log;
      }
      EXPECT_FALSE(fs::exists(out / "summary.json"));
    } else {
      std::cerr << "note: " << c.name << " finished before the signal; resuming from stage "
                << c.after << "'s checkpoint\n";
    }
    const long long from = checkpoint_stage(out);
    EXPECT_GE(from, c.after);
    EXPECT_LT(from, stages);
    // What a kill during a checkpoint write leaves: the temporary, cut short (the resume
    // removes it).
    std::ofstream(out / ".checkpoint.h5.partial-999999") << "cut short";
    const testing::CliRun r = resume(args, out, c.resume_threads);
    ASSERT_EQ(r.exit_code, 0) << r.all();
    EXPECT_NE(r.err.find("resuming after stage " + std::to_string(from)), std::string::npos)
        << r.err;
    expect_same_posterior(straight, out);
    const json t = json::parse(read_text(out / "summary.json"))["timing"];
    EXPECT_EQ(t["resumed_from_stage"], from);
    EXPECT_EQ(t["threads"], c.resume_threads);
    // No temporary left behind by the killed run's writes.
    for (const auto& e : fs::directory_iterator(out))
      EXPECT_EQ(e.path().filename().string().find(".partial"), std::string::npos) << e.path();
  }
}

TEST(InferResume, MpiRunWithAKilledRankResumesOnOneRankToTheStraightPosterior) {
  if (kMpirun.empty()) GTEST_SKIP() << "mpirun not found";
  const fs::path dir = testing::fresh_output_dir("infer_resume_mpi");
  const auto args = problem_args(data_file(dir));
  const std::vector<std::string> np2 = {
      kMpirun, "--allow-run-as-root", "--oversubscribe", "-np", "2", "-x", "OMP_NUM_THREADS",
      "-x",    "OMP_WAIT_POLICY"};
  const fs::path straight = dir / "straight";
  const testing::CliRun s =
      shell(joined(np2) + " " + kRbc + " " + joined(args) + " -q --out " + straight.string());
  ASSERT_EQ(s.exit_code, 0) << s.all();
  const long long stages = json::parse(read_text(straight / "summary.json"))["stages"];

  const fs::path out = dir / "killed";
  const Interrupted k = interrupt_run(args, out, "stage 2:", SIGKILL, 1, np2, /*rank=*/1);
  ASSERT_NE(k.exit_code, -1000) << k.log;
  if (k.mid_run) {
    EXPECT_NE(k.exit_code, 0) << k.log;
    EXPECT_NE(k.log.find("rank 1"), std::string::npos) << "the message names the rank: " << k.log;
    EXPECT_FALSE(fs::exists(out / "summary.json"));
  }
  const long long from = checkpoint_stage(out);
  EXPECT_GE(from, 2);
  EXPECT_LT(from, stages);
  const std::string np1 = kMpirun +
                          " --allow-run-as-root --oversubscribe -np 1 -x OMP_NUM_THREADS -x "
                          "OMP_WAIT_POLICY";
  const testing::CliRun r =
      shell(np1 + " " + kRbc + " " + joined(args) + " --resume " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.all();
  expect_same_posterior(straight, out);
  EXPECT_EQ(json::parse(read_text(out / "summary.json"))["timing"]["ranks"], 1);

  // SIGTERM to rank 0's own process under mpirun (mpirun would pass a signal it gets to every
  // rank and kill them about a second later, maybe before rank 0 speaks): rank 0 stops after
  // the chains in flight, says where the last complete stage is, releases the workers and
  // exits 143 (so mpirun fails); the resume from that stage gives the straight posterior.
  const fs::path term = dir / "term";
  const Interrupted t = interrupt_run(args, term, "stage 1:", SIGTERM, 1, np2, /*rank=*/0);
  ASSERT_NE(t.exit_code, -1000) << "stage 1 never reported: " << t.log;
  ASSERT_TRUE(t.mid_run) << "the run finished before SIGTERM reached rank 0: " << t.log;
  EXPECT_NE(t.exit_code, 0) << t.log;
  EXPECT_NE(
      t.log.find("rbc: SIGTERM received: stopping; the last complete stage is in " +
                 (term / "checkpoint.h5").string() + ", continue with --resume " + term.string()),
      std::string::npos)
      << t.log;
  EXPECT_NE(t.log.find("rbc: interrupted by SIGTERM"), std::string::npos) << t.log;
  EXPECT_FALSE(fs::exists(term / "summary.json"));
  const long long term_from = checkpoint_stage(term);
  EXPECT_GE(term_from, 1);
  EXPECT_LT(term_from, stages);
  const testing::CliRun tr =
      shell(np1 + " " + kRbc + " " + joined(args) + " --resume " + term.string());
  ASSERT_EQ(tr.exit_code, 0) << tr.all();
  EXPECT_NE(tr.out.find("resuming after stage " + std::to_string(term_from)), std::string::npos)
      << tr.out;
  expect_same_posterior(straight, term);
}

/// Exit 2, one "rbc: error:" line naming `expect`, and nothing new in the directory.
void expect_refused(const std::string& args, const std::string& expect, const fs::path& dir) {
  SCOPED_TRACE(args);
  std::vector<std::string> before;
  if (fs::exists(dir))
    for (const auto& e : fs::directory_iterator(dir)) before.push_back(e.path().filename());
  const testing::CliRun r = testing::run_rbc(args, 1);
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_EQ(r.err.rfind("rbc: error: ", 0), 0u) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
  EXPECT_NE(r.err.find(expect), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("beta ="), std::string::npos) << "work started: " << r.err;
  std::vector<std::string> after;
  if (fs::exists(dir))
    for (const auto& e : fs::directory_iterator(dir)) after.push_back(e.path().filename());
  std::sort(before.begin(), before.end());
  std::sort(after.begin(), after.end());
  EXPECT_EQ(before, after);
}

TEST(InferResume, MissingCorruptOrForeignCheckpointsAndBadSeedsExitTwoBeforeWork) {
  const fs::path dir = testing::fresh_output_dir("infer_resume_refusals");
  const std::string data = data_file(dir);
  // A cheap run of three stages (20 samples, one Metropolis step).
  const std::vector<std::string> args = {
      "infer",     "--method", "continuum:2:200",         "--sampler",   "tmcmc",
      "--samples", "20",       "--chain-length",          "1",           "--seed",
      "3",         "--params", "persistence,sigma-scale", "--data-file", data};
  const fs::path run = dir / "run";
  const testing::CliRun s = testing::run_rbc(joined(args) + " -q --out " + run.string(), 1);
  ASSERT_EQ(s.exit_code, 0) << s.all();
  const std::string base = joined(args);
  const auto seed_at = static_cast<std::size_t>(
      std::find(args.begin(), args.end(), std::string("--seed")) - args.begin() + 1);

  expect_refused(base + " --resume " + (dir / "nowhere").string(), "no such directory", dir);
  fs::create_directories(dir / "empty");
  expect_refused(base + " --resume " + (dir / "empty").string(), "no checkpoint.h5", dir / "empty");
  // Another seed, another data file: the inputs that differ are named with both values.
  {
    std::vector<std::string> other = args;
    other[seed_at] = "4";
    expect_refused(joined(other) + " --resume " + run.string(), "--seed (checkpoint 3, this run 4)",
                   run);
    other[seed_at] = "18446744073709551615";  // the largest seed parses (and differs)
    expect_refused(joined(other) + " --resume " + run.string(), "this run 18446744073709551615",
                   run);
    const fs::path data2 = dir / "other.csv";
    std::ofstream(data2) << read_text(data) << "120,14.5,1.2,4.3,0.6\n";
    other = args;
    other.back() = data2.string();
    expect_refused(joined(other) + " --resume " + run.string(), "--data-file contents", run);
  }
  expect_refused(base + " --out " + (dir / "elsewhere").string() + " --resume " + run.string(),
                 "own directory", run);
  // A new run into a directory holding a checkpoint names --resume.
  expect_refused(base + " --out " + run.string(), "--resume " + run.string(), run);
  // Seeds outside [0, 2^64 - 1] (they once wrapped around).
  for (const char* seed : {"-1", "18446744073709551616", "1e3", "3x"}) {
    std::vector<std::string> bad = args;
    bad[seed_at] = seed;
    expect_refused(joined(bad) + " --out " + (dir / "never").string(), seed, dir / "never");
    EXPECT_FALSE(fs::exists(dir / "never"));
  }
  // A corrupt checkpoint: one byte of the stored samples changed.
  {
    const fs::path bad = dir / "corrupt";
    fs::create_directories(bad);
    fs::copy_file(run / "checkpoint.h5", bad / "checkpoint.h5");
    ASSERT_TRUE(flip_dataset_byte(bad / "checkpoint.h5", "/population/theta"));
    expect_refused(base + " --resume " + bad.string(), "is corrupt", bad);
    std::ofstream(bad / "checkpoint.h5") << "not HDF5";
    expect_refused(base + " --resume " + bad.string(), "checkpoint.h5", bad);
  }
}

}  // namespace
}  // namespace rbc
