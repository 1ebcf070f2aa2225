// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc mc --forces ... --out DIR` keeps a checkpoint per force in DIR/checkpoints/ and
// `--resume DIR` continues the list: a list stopped by SIGTERM in the middle of a force (one
// process, or rank 0 of `mpirun -np 2`) resumes, on another thread count or rank count, to the
// thermal curve of a straight run, number for number; finished forces are not run again. A
// resume with another force list, another seed, a corrupt checkpoint or a foreign --out, and a
// fresh run into the directory, are refused with exit 2 and one line before any work.
//
// The list: 150 vertices, forces 0, 20, 40 pN, 200 sweeps of two chains, a checkpoint every 20
// sweeps (some 0.3 s per force here), so a signal at force 1's checkpoint of sweep 40 lands in
// the middle of force 1.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_run.hpp"
#include "core/h5file.hpp"
#include "infer_resume_helpers.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

using namespace testing::infer_resume;

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kRbc = std::string(RBC_BINARY_DIR) + "/rbc";
const std::string kMpirun = RBC_MPIRUN;

std::vector<std::string> list_args(const std::string& forces = "0,20,40",
                                   const std::string& seed = "3") {
  return {"mc",       "-n",           "150",      "--forces", forces,
          "--sweeps", "200",          "--seed",   seed,       "--checkpoint-every",
          "20",       "--no-picture", "--verbose"};
}

/// The data lines of a CSV file (its comment lines name the command line and the date).
std::string data_lines(const fs::path& p) {
  std::ifstream in(p);
  std::string text;
  for (std::string line; std::getline(in, line);)
    if (line.rfind('#', 0) != 0) text += line + "\n";
  return text;
}

long long checkpoint_sweep(const fs::path& p) {
  return H5File::open_read(p.string()).read_attribute_int("sweep");
}

/// The curve a straight run wrote in dir, and the series of every force: what a resumed run
/// must reproduce exactly.
void expect_same_curve(const fs::path& straight, const fs::path& other) {
  SCOPED_TRACE(straight.string() + " vs " + other.string());
  const std::string curve = data_lines(straight / "thermal_curve.csv");
  ASSERT_NE(std::count(curve.begin(), curve.end(), '\n'), 0);
  EXPECT_EQ(curve, data_lines(other / "thermal_curve.csv"));
  EXPECT_EQ(json::parse(read_text(straight / "thermal_curve.json"))["curve"],
            json::parse(read_text(other / "thermal_curve.json"))["curve"]);
  for (const char* f : {"force_00/mc_series.csv", "force_01/mc_series.csv",
                        "force_01/mc_series_chain1.csv", "force_02/mc_series_chain1.csv"})
    EXPECT_EQ(data_lines(straight / f), data_lines(other / f)) << f;
}

TEST(McForcesResume, SigtermedListResumesToTheStraightCurveOnAnotherThreadCount) {
  const fs::path dir = testing::fresh_output_dir("mc_forces_resume_threads");
  const auto args = list_args();
  const fs::path straight = dir / "straight", straight2 = dir / "straight_t2";
  const testing::CliRun s = testing::run_rbc(joined(args) + " -q --out " + straight.string(), 1);
  ASSERT_EQ(s.exit_code, 0) << s.all();
  // A straight run on two threads gives the same curve.
  const testing::CliRun s2 = testing::run_rbc(joined(args) + " -q --out " + straight2.string(), 2);
  ASSERT_EQ(s2.exit_code, 0) << s2.all();
  expect_same_curve(straight, straight2);
  // Every force of a straight run ends with its checkpoint at --sweeps.
  for (const char* f : {"force_00.h5", "force_01.h5", "force_02.h5"})
    EXPECT_EQ(checkpoint_sweep(straight / "checkpoints" / f), 200) << f;

  const fs::path out = dir / "killed";
  std::vector<std::string> a = args;
  a.insert(a.end(), {"--out", out.string()});
  const Signalled k = signal_at_marker(a, dir / "killed.log",
                                       "force 1 (20 pN): checkpoint at sweep 40", SIGTERM, 1);
  ASSERT_TRUE(k.seen) << k.log;
  ASSERT_EQ(k.exit_code, 143) << "the signal must land before the list ends: " << k.log;
  const std::string how = "rbc: interrupted by SIGTERM: checkpoints of the forces in " +
                          (out / "checkpoints").string() +
                          "; continue with the same options and --resume " + out.string() + "\n";
  EXPECT_NE(k.log.find(how), std::string::npos) << k.log;
  EXPECT_EQ(std::count(k.log.begin(), k.log.end(), '\n'),
            std::count(k.log.begin(), k.log.end(), '[') + 1)
      << "one line besides the progress: " << k.log;
  EXPECT_FALSE(fs::exists(out / "thermal_curve.csv"));
  EXPECT_EQ(checkpoint_sweep(out / "checkpoints" / "force_00.h5"), 200);  // finished
  const long long at = checkpoint_sweep(out / "checkpoints" / "force_01.h5");
  EXPECT_GE(at, 40);
  EXPECT_LT(at, 200);
  // Written on the way out, at the sweep the chains stopped.
  EXPECT_NE(
      k.log.find("force 1 (20 pN): checkpoint at sweep " + std::to_string(at) + " (interrupted)"),
      std::string::npos)
      << k.log;
  EXPECT_FALSE(fs::exists(out / "checkpoints" / "force_02.h5"));  // never started
  // What a kill during a checkpoint write leaves: a temporary, cut short (the resume removes it).
  std::ofstream(out / "checkpoints" / ".force_01.h5.partial-999999") << "cut short";
  const std::string finished = read_text(out / "checkpoints" / "force_00.h5");

  const testing::CliRun r = testing::run_rbc(joined(args) + " --resume " + out.string(), 2);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  EXPECT_NE(r.err.find("force 0 (0 pN): finished, from"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("force 1 (20 pN): resuming at sweep " + std::to_string(at)),
            std::string::npos)
      << r.err;
  // The finished force ran no sweep: its checkpoint is untouched, no new one was written.
  EXPECT_EQ(read_text(out / "checkpoints" / "force_00.h5"), finished);
  EXPECT_EQ(r.err.find("force 0 (0 pN): checkpoint"), std::string::npos) << r.err;
  expect_same_curve(straight, out);
  EXPECT_FALSE(fs::exists(out / "checkpoints" / ".force_01.h5.partial-999999"));
  // Resuming the finished list again reproduces the curve without a sweep.
  const testing::CliRun again = testing::run_rbc(joined(args) + " --resume " + out.string(), 1);
  ASSERT_EQ(again.exit_code, 0) << again.all();
  EXPECT_EQ(again.err.find("checkpoint at sweep"), std::string::npos) << again.err;
  expect_same_curve(straight, out);
}

/// Exit 2, one "rbc: error:" line naming `expect`, and the directory's files unchanged.
void expect_refused(const std::string& args, const std::string& expect, const fs::path& dir) {
  SCOPED_TRACE(args);
  auto listing = [&] {
    std::vector<std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file()) files.push_back(e.path().string() + " " + read_text(e.path()));
    std::sort(files.begin(), files.end());
    return files;
  };
  const std::vector<std::string> before = listing();
  const testing::CliRun r = testing::run_rbc(args, 1);
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_EQ(r.err.rfind("rbc: error: ", 0), 0u) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
  EXPECT_NE(r.err.find(expect), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_TRUE(listing() == before) << "the directory changed";
}

TEST(McForcesResume, ChangedOptionsOrCorruptCheckpointsAreRefusedWithExit2BeforeWork) {
  const fs::path dir = testing::fresh_output_dir("mc_forces_resume_refusals");
  const fs::path run = dir / "run";
  const testing::CliRun s =
      testing::run_rbc(joined(list_args("0,20")) + " -q --out " + run.string(), 1);
  ASSERT_EQ(s.exit_code, 0) << s.all();
  const std::string resume = " --resume " + run.string();
  expect_refused(joined(list_args("0,20,40")) + resume, "--forces differs", run);
  expect_refused(joined(list_args("0,20", "4")) + resume, "--seed differs", run);
  expect_refused(joined(list_args("0,20")) + " --chains 3" + resume, "--chains differs", run);
  expect_refused(joined(list_args("0,20")) + " --temperature 310" + resume, "--temperature differs",
                 run);
  expect_refused(joined(list_args("0,20")) + " --resume " + (dir / "nowhere").string(),
                 "no such directory", run);
  expect_refused(joined(list_args("0,20")) + " --out " + (dir / "elsewhere").string() + resume,
                 "its own directory", run);
  EXPECT_FALSE(fs::exists(dir / "elsewhere"));
  // A fresh run into the directory names --resume.
  expect_refused(joined(list_args("0,20")) + " --out " + run.string(), "--resume " + run.string(),
                 run);
  // The same list resumes (nothing to do: every force finished).
  const testing::CliRun same = testing::run_rbc(joined(list_args("0,20")) + " -q" + resume, 1);
  EXPECT_EQ(same.exit_code, 0) << same.all();
  // A corrupt checkpoint: one byte of force 1's positions changed.
  ASSERT_TRUE(flip_dataset_byte(run / "checkpoints" / "force_01.h5", "/chain_0/positions_um"));
  expect_refused(joined(list_args("0,20")) + resume, "is corrupt", run);
  // A directory without a force list.
  fs::create_directories(dir / "empty");
  expect_refused(joined(list_args("0,20")) + " --resume " + (dir / "empty").string(),
                 "checkpoints/force_list.json", dir / "empty");
}

TEST(McForcesResume, MpiListStoppedOnRankZeroResumesOnOneProcessToTheStraightCurve) {
  if (kMpirun.empty()) GTEST_SKIP() << "mpirun not found";
  const fs::path dir = testing::fresh_output_dir("mc_forces_resume_mpi");
  const auto args = list_args();
  const fs::path straight = dir / "straight";
  const testing::CliRun s = testing::run_rbc(joined(args) + " -q --out " + straight.string(), 1);
  ASSERT_EQ(s.exit_code, 0) << s.all();
  const std::vector<std::string> np2 = {
      kMpirun, "--allow-run-as-root", "--oversubscribe", "-np", "2", "-x", "OMP_NUM_THREADS",
      "-x",    "OMP_WAIT_POLICY"};
  // Rank 0 runs forces 0 and 2, rank 1 force 1; SIGTERM to rank 0 in force 0 after its
  // checkpoint at sweep 40: rank 0 checkpoints, says how to continue and stops every rank.
  const fs::path out = dir / "killed";
  std::vector<std::string> a = args;
  a.insert(a.end(), {"--out", out.string()});
  const Signalled k = signal_at_marker(a, dir / "killed.log",
                                       "force 0 (0 pN): checkpoint at sweep 40", SIGTERM, 1, np2,
                                       /*rank=*/0);
  ASSERT_TRUE(k.seen) << k.log;
  EXPECT_NE(k.exit_code, 0) << k.log;
  EXPECT_NE(k.log.find("rbc: interrupted by SIGTERM: checkpoints of the forces in " +
                       (out / "checkpoints").string()),
            std::string::npos)
      << k.log;
  EXPECT_FALSE(fs::exists(out / "thermal_curve.csv"));
  const long long at = checkpoint_sweep(out / "checkpoints" / "force_00.h5");
  EXPECT_GE(at, 40);
  EXPECT_LT(at, 200);
  EXPECT_NE(
      k.log.find("force 0 (0 pN): checkpoint at sweep " + std::to_string(at) + " (interrupted)"),
      std::string::npos)
      << k.log;
  const testing::CliRun r = shell(kMpirun +
                                  " --allow-run-as-root --oversubscribe -np 1 -x OMP_NUM_THREADS "
                                  "-x OMP_WAIT_POLICY " +
                                  kRbc + " " + joined(args) + " --resume " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.all();
  EXPECT_NE(r.out.find("force 0 (0 pN): resuming at sweep " + std::to_string(at)),
            std::string::npos)
      << r.out;
  expect_same_curve(straight, out);
}

}  // namespace
}  // namespace rbc
