// SPDX-License-Identifier: GPL-3.0-or-later
// Runtime reliability of the `rbc` executable (start-up continuation, corrupt checkpoints,
// interrupts, resume): random SIGINT/SIGTERM interrupts leave no temporary file, only complete and
// readable outputs, a manifest that says what is complete and a checkpoint that resumes; exit
// 130/143; extending a finished Monte Carlo run continues it exactly as a straight run of the new
// length.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cli_run.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"
#include "core/rest_shape.hpp"
#include "discrete/mc_checkpoint.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/stretch.hpp"
#include "fixtures.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// `rbc args...` in the background with the environment's OpenMP threads (cli_run.hpp).
pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  return testing::spawn_rbc(args, log, 0);
}

/// What wait_for() returns for a child that did not end in time, and that time.
constexpr int kHung = -1000;
constexpr std::chrono::seconds kRunLimit{120};

/// Exit code of a child, or -signal if a signal killed it. An interrupted run must end, so a
/// child still running after kRunLimit is a hang: the stacks of its threads are appended to
/// `log` (by gdb, when installed), it is killed and the result is kHung.
int wait_for(pid_t pid, const std::string& log) {
  const auto deadline = std::chrono::steady_clock::now() + kRunLimit;
  int status = 0;
  while (true) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    if (r < 0 && errno != EINTR) throw std::runtime_error("waitpid failed for a spawned rbc");
    if (std::chrono::steady_clock::now() > deadline) {
      const std::string gdb = "gdb -p " + std::to_string(pid) +
                              " -batch -ex 'thread apply all bt' >> '" + log + "' 2>&1";
      if (std::system("command -v gdb > /dev/null 2>&1") == 0)
        (void)!std::system(gdb.c_str());  // best effort: the kill below does not depend on it
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return kHung;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

struct CommandRun {
  int exit_code;
  std::string output;  // stderr then stdout: messages and failure reports
  std::string out;     // stdout alone: the JSON
  std::string err;     // stderr alone
};
/// `rbc ARGS` on `threads` OpenMP threads (every comparison between processes runs pinned).
CommandRun rbc(const std::string& args, int threads = 2) {
  const testing::CliRun r = testing::run_rbc(args, threads);
  return {r.exit_code, r.all(), r.out, r.err};
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Every file under `dir` whose name marks an atomic writer's temporary.
std::vector<std::string> temporaries_in(const fs::path& dir) {
  std::vector<std::string> t;
  if (!fs::exists(dir)) return t;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".partial") != std::string::npos)
      t.push_back(e.path().string());
  return t;
}

int count_files(const fs::path& dir, const std::string& prefix, const std::string& ext) {
  int n = 0;
  if (!fs::exists(dir)) return 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) == 0 && e.path().extension() == ext) ++n;
  }
  return n;
}

/// The outputs of an interrupted (or finished) `stretch --out`: complete shapes (HDF5 opens,
/// XDMF present), as many as run.json lists; run.json says complete only for exit 0.
void check_stretch_outputs(const fs::path& dir, int code, int sig, const std::string& trial) {
  SCOPED_TRACE(trial);
  if (code == -sig) {  // the signal came before main() installed its handlers: nothing written
    EXPECT_FALSE(fs::exists(dir));
    return;
  }
  EXPECT_TRUE(code == 0 || code == 128 + sig) << "exit " << code;
  const fs::path manifest = dir / "run.json";
  if (!fs::exists(manifest)) {
    // Interrupted before the network was built: nothing written at all.
    EXPECT_NE(code, 0);
    EXPECT_EQ(count_files(dir, "", ".h5"), 0);
    EXPECT_FALSE(fs::exists(dir / "stretch.csv"));
    return;
  }
  const json j = json::parse(slurp(manifest));
  EXPECT_EQ(j.at("complete").get<bool>(), code == 0) << j.dump();
  EXPECT_EQ(j.at("status").get<std::string>(), code == 0 ? "finished" : "interrupted") << j.dump();
  const auto& done = j.at("forces_complete");
  EXPECT_EQ(static_cast<int>(done.size()), count_files(dir, "shape_", ".h5"));
  for (const auto& f : done) {
    const fs::path h5 = dir / f.at("shape_h5").get<std::string>();
    EXPECT_TRUE(fs::exists(dir / f.at("shape_xdmf").get<std::string>())) << h5;
    try {
      const H5File h = H5File::open_read(h5.string());
      std::vector<double> x;
      EXPECT_EQ(h.read("/mesh/positions_um", x).second, 3u);
      EXPECT_EQ(h.read_attribute_double("force_pN"), f.at("force_pN").get<double>());
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
    }
  }
  if (code == 0) {
    EXPECT_EQ(done.size(), 3u);
    EXPECT_EQ(read_csv((dir / "stretch.csv").string()).rows.size(), 3u);
  } else {
    EXPECT_FALSE(fs::exists(dir / "stretch.csv"));
    EXPECT_NE(j.at("reason").get<std::string>().find(sig == SIGINT ? "SIGINT" : "SIGTERM"),
              std::string::npos);
  }
}

/// The outputs of an interrupted `mc --checkpoint --out`: a final checkpoint at the sweep
/// run.json names, which reads back against the network; series and snapshots complete.
/// Returns the sweeps done (-1 if the chain never started).
long long check_mc_outputs(const fs::path& dir, const fs::path& checkpoint, const Network& net,
                           int code, int sig, const std::string& trial) {
  SCOPED_TRACE(trial);
  if (code == -sig) {  // the signal came before main() installed its handlers: nothing written
    EXPECT_FALSE(fs::exists(dir));
    EXPECT_FALSE(fs::exists(checkpoint));
    return -1;
  }
  EXPECT_EQ(code, 128 + sig);  // 100,000 sweeps never finish in the test
  const fs::path manifest = dir / "run.json";
  if (!fs::exists(manifest)) {
    EXPECT_FALSE(fs::exists(checkpoint));
    EXPECT_EQ(count_files(dir, "", ".h5"), 0);
    return -1;
  }
  const json j = json::parse(slurp(manifest));
  EXPECT_FALSE(j.at("complete").get<bool>());
  EXPECT_EQ(j.at("status").get<std::string>(), "interrupted") << j.dump();
  const long long sweeps = j.at("sweeps_done").get<long long>();
  try {
    const McCheckpoint cp = read_mc_checkpoint(checkpoint.string(), net);
    EXPECT_EQ(cp.chain.sweep, sweeps);  // the final checkpoint, written on the way out
    EXPECT_EQ(static_cast<long long>(cp.series.size()), sweeps);
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what();
  }
  EXPECT_EQ(static_cast<long long>(read_csv((dir / "mc_series.csv").string()).rows.size()), sweeps);
  try {
    const H5File h = H5File::open_read((dir / "mc_series.h5").string());
    if (sweeps > 0) {
      std::vector<double> rows;
      EXPECT_EQ(static_cast<long long>(h.read("/series", rows).first), sweeps);
    }
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what();
  }
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("mc_snapshot_", 0) != 0 || e.path().extension() != ".h5") continue;
    EXPECT_TRUE(fs::exists(fs::path(e.path()).replace_extension(".xdmf"))) << name;
    try {
      std::vector<double> x;
      EXPECT_EQ(H5File::open_read(e.path().string()).read("/mesh/positions_um", x).second, 3u);
    } catch (const std::exception& ex) {
      ADD_FAILURE() << ex.what();
    }
  }
  return sweeps;
}

TEST(ReliabilityRuntime, HundredRandomInterruptsLeaveOnlyCompleteOutputs) {
  // Cases 39 and 40: 50 stretch + 50 Monte Carlo runs, each sent SIGINT or SIGTERM after a
  // random delay (seeded), two at a time. The delays cover start-up, the solves and the writes.
  const fs::path root = testing::fresh_output_dir("reliability_interrupts");
  const Network net = [] {
    testing::OneOpenMpThread one;  // as `rbc mc` builds it (bit-identical rest shape)
    RestShapeOptions ro;
    ro.target_vertices = 300;
    return build_network(make_rest_shape(ro), NetworkParameters{});
  }();
  std::mt19937 rng(2026);
  // stretch: 0.8 s at full speed; mc: its first sweep comes after ~0.5-1 s of set-up.
  std::uniform_real_distribution<double> stretch_delay_s(0.01, 1.0), mc_delay_s(0.2, 1.8);
  int interrupted = 0, finished = 0, resumed = 0, partial_stretch = 0, chains_checkpointed = 0;
  for (int pair = 0; pair < 50; ++pair) {
    const std::string tag = std::to_string(pair);
    const fs::path sdir = root / ("stretch_" + tag), mdir = root / ("mc_" + tag);
    const fs::path ckpt = root / ("mc_" + tag + ".h5");
    const int ssig = rng() % 2 ? SIGINT : SIGTERM, msig = rng() % 2 ? SIGINT : SIGTERM;
    const double sdelay = stretch_delay_s(rng), mdelay = mc_delay_s(rng);
    const std::string slog = (root / ("stretch_" + tag + ".log")).string(),
                      mlog = (root / ("mc_" + tag + ".log")).string();
    const pid_t s = spawn(
        {"stretch", "--vertices", "300", "--force", "0,16,38", "--out", sdir.string(), "-q"}, slog);
    const pid_t m =
        spawn({"mc", "--vertices", "300", "--sweeps", "100000", "--checkpoint", ckpt.string(),
               "--checkpoint-every", "1", "--out", mdir.string(), "--snapshot-every", "3", "-q"},
              mlog);
    const auto t0 = std::chrono::steady_clock::now();
    auto at = [&](double sec) {
      std::this_thread::sleep_until(t0 + std::chrono::duration<double>(sec));
    };
    if (sdelay < mdelay) {
      at(sdelay);
      kill(s, ssig);
      at(mdelay);
      kill(m, msig);
    } else {
      at(mdelay);
      kill(m, msig);
      at(sdelay);
      kill(s, ssig);
    }
    const int scode = wait_for(s, slog), mcode = wait_for(m, mlog);
    const std::string strial = "stretch trial " + tag + ", signal " + std::to_string(ssig) +
                               " after " + std::to_string(sdelay) + " s";
    const std::string mtrial = "mc trial " + tag + ", signal " + std::to_string(msig) + " after " +
                               std::to_string(mdelay) + " s";
    const std::pair<int, const std::string*> runs[] = {{scode, &slog}, {mcode, &mlog}};
    for (const auto& [code, log] : runs)
      if (code == kHung)
        ADD_FAILURE() << (log == &slog ? strial : mtrial) << ": the run did not end within "
                      << kRunLimit.count() << " s; killed. Its log and stacks:\n"
                      << slurp(*log);
    if (scode == kHung || mcode == kHung) continue;
    EXPECT_EQ(temporaries_in(sdir), std::vector<std::string>{}) << strial;
    EXPECT_EQ(temporaries_in(mdir), std::vector<std::string>{}) << mtrial;
    check_stretch_outputs(sdir, scode, ssig, strial);
    const long long sweeps = check_mc_outputs(mdir, ckpt, net, mcode, msig, mtrial);
    interrupted += (scode != 0) + (mcode != 0);
    partial_stretch += scode != 0 && count_files(sdir, "shape_", ".h5") > 0;
    chains_checkpointed += sweeps > 0;
    finished += scode == 0;
    // Every checkpoint resumes (read back above); the first few also through the CLI.
    if (sweeps >= 0 && resumed < 4) {
      const CommandRun r = rbc("mc --resume " + ckpt.string() + " --sweeps " +
                               std::to_string(sweeps + 3) + " -q --json");
      EXPECT_EQ(r.exit_code, 0) << mtrial << "\n" << r.output;
      if (r.exit_code == 0) {
        EXPECT_EQ(json::parse(r.out).at("sweeps").get<long long>(), sweeps + 3);
      }
      ++resumed;
    }
    if (!HasFailure()) {
      fs::remove_all(sdir);
      fs::remove_all(mdir);
      fs::remove(ckpt);
    }
  }
  // One interrupt that surely comes after the first checkpoint (the random delays above may all
  // come before it on a slow machine or under a sanitizer): the signal is sent once the
  // checkpoint file exists, and that checkpoint must resume through the CLI.
  {
    const fs::path mdir = root / "mc_after_checkpoint", ckpt = root / "mc_after_checkpoint.h5";
    const std::string mlog = (root / "mc_after_checkpoint.log").string();
    const pid_t m = spawn({"mc", "--vertices", "300", "--sweeps", "100000", "--checkpoint",
                           ckpt.string(), "--checkpoint-every", "1", "--out", mdir.string(), "-q"},
                          mlog);
    const auto deadline = std::chrono::steady_clock::now() + kRunLimit;  // a hang guard only
    while (!fs::exists(ckpt) && std::chrono::steady_clock::now() < deadline &&
           waitpid(m, nullptr, WNOHANG) == 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    kill(m, SIGTERM);
    const int code = wait_for(m, mlog);
    ASSERT_NE(code, kHung) << slurp(mlog);
    const long long sweeps = check_mc_outputs(mdir, ckpt, net, code, SIGTERM, "after checkpoint");
    ASSERT_GE(sweeps, 1) << slurp(mlog);
    const CommandRun r = rbc("mc --resume " + ckpt.string() + " --sweeps " +
                             std::to_string(sweeps + 3) + " -q --json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(json::parse(r.out).at("sweeps").get<long long>(), sweeps + 3);
  }
  EXPECT_EQ(temporaries_in(root), std::vector<std::string>{});
  // What the random delays covered (not asserted: it depends on the machine's speed).
  RecordProperty("interrupted", interrupted);
  RecordProperty("finished_first", finished);
  RecordProperty("stretch_interrupted_with_some_shapes", partial_stretch);
  RecordProperty("mc_interrupted_after_sweeps", chains_checkpointed);
  std::cout << "interrupted " << interrupted << ", stretch finished first " << finished
            << ", stretch interrupted with some shapes " << partial_stretch
            << ", mc interrupted after >= 1 sweep " << chains_checkpointed << "\n";
}

TEST(ReliabilityRuntime, ExtendingAFinishedMonteCarloRunMatchesTheStraightRun) {
  // Case 41: 200 sweeps, then --resume to 400, against a straight 400-sweep run. With the
  // adaptive phase given in absolute sweeps both chains are the same: every JSON field agrees
  // bit for bit except the timing ones and sweeps_this_run.
  const fs::path dir = testing::fresh_output_dir("reliability_extend");
  const std::string base = "mc -n 150 --streams 2 --seed 5 --force 20 -q --json ";
  const std::string c = (dir / "c.h5").string();
  const CommandRun first = rbc(base + "--sweeps 200 --adapt-sweeps 80 --checkpoint " + c);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const CommandRun extended = rbc("mc -q --json --resume " + c + " --sweeps 400");
  ASSERT_EQ(extended.exit_code, 0) << extended.output;
  const CommandRun straight = rbc(base + "--sweeps 400 --adapt-sweeps 80");
  ASSERT_EQ(straight.exit_code, 0) << straight.output;
  json a = json::parse(extended.out), b = json::parse(straight.out);
  // running_total_drift_*: the round-off of the sampler's running totals since this process
  // (re)built them, a diagnostic that restarts on resume by design (1e-13 um^2 here).
  // command, config, provenance: the run record, which names each command as given.
  for (const char* k :
       {"wall_s", "sweeps_per_s", "moves_per_s", "sweeps_this_run", "running_total_drift_area_um2",
        "running_total_drift_volume_um3", "command", "config", "provenance"}) {
    a.erase(k);
    b.erase(k);
  }
  EXPECT_EQ(a.dump(), b.dump());
  EXPECT_EQ(a.at("sweeps").get<long long>(), 400);
  EXPECT_FALSE(a.contains("resume_note"));

  // With the default --adapt-fraction the first leg adapted 20 % of 200 = 40 sweeps, a straight
  // 400-sweep run adapts 80: the resumed run keeps 40 and says exactly that.
  const CommandRun f2 = rbc(base + "--sweeps 200 --checkpoint " + c);
  ASSERT_EQ(f2.exit_code, 0) << f2.output;
  const CommandRun e2 = rbc("mc -q --json --resume " + c + " --sweeps 400");
  ASSERT_EQ(e2.exit_code, 0) << e2.output;
  const json n = json::parse(e2.out);
  EXPECT_EQ(n.at("adaptive_sweeps").get<int>(), 40);
  const std::string note = n.at("resume_note").get<std::string>();
  EXPECT_NE(note.find("1-40"), std::string::npos) << note;
  EXPECT_NE(note.find("1-80"), std::string::npos) << note;
  // Resuming with the length the checkpoint planned for is the interrupted-run case: no note.
  const CommandRun f3 = rbc(base + "--sweeps 200 --checkpoint " + c);
  ASSERT_EQ(f3.exit_code, 0);
  EXPECT_FALSE(
      json::parse(rbc("mc -q --json --resume " + c + " --sweeps 200").out).contains("resume_note"));
}

TEST(ReliabilityRuntime, OlderCheckpointFormatIsRefusedWithExitTwo) {
  const fs::path dir = testing::fresh_output_dir("reliability_format");
  const std::string old = (dir / "v2.h5").string();
  {
    H5File h = H5File::create(old);
    h.write_attribute("format", 2LL);
    h.write_attribute("vertices", 150LL);
    h.write_attribute("bending_model", std::string("juelicher"));
  }
  const CommandRun r = rbc("mc --resume " + old + " --sweeps 10 -q");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("rbc: error: checkpoint '" + old + "' has format version 2"),
            std::string::npos)
      << r.output;
}

/// The JSON fields of an `rbc mc --json` run that describe the chain (timings, the round-off
/// diagnostic of the running totals, which restarts in every process, and the run record, which
/// names the command line and the date, left out).
json chain_fields(const std::string& out) {
  json j = json::parse(out);
  for (const char* k : {"wall_s", "sweeps_per_s", "moves_per_s", "running_total_drift_area_um2",
                        "running_total_drift_volume_um3", "command", "config", "provenance"})
    j.erase(k);
  return j;
}

TEST(ReliabilityRuntime, DefaultMonteCarloChainDoesNotDependOnTheThreadCount) {
  // The default number of RNG streams is fixed (not one per thread): the same command on one
  // and on two OpenMP threads samples the same chain, field for field.
  const std::string args = "mc -n 150 --force 20 --sweeps 40 -q --json";
  const CommandRun one = rbc(args, 1), two = rbc(args, 2);
  ASSERT_EQ(one.exit_code, 0) << one.output;
  ASSERT_EQ(two.exit_code, 0) << two.output;
  json a = chain_fields(one.out), b = chain_fields(two.out);
  // The thread decision: the first runs its two chains one after the other, the second (two
  // threads available) one chain per thread.
  EXPECT_EQ(a.at("threads").at("used").get<int>(), 1);
  EXPECT_EQ(a.at("threads").at("requested").get<int>(), 1);
  EXPECT_EQ(b.at("threads").at("used").get<int>(), 2);
  EXPECT_EQ(b.at("threads").at("requested").get<int>(), 2);
  a.erase("threads");
  b.erase("threads");
  EXPECT_EQ(a, b);
  EXPECT_EQ(a.at("streams").get<int>(), 2);
}

TEST(ReliabilityRuntime, CorruptCheckpointIsRefusedWithExitTwo) {
  // Bytes changed in a valid checkpoint: the resume is refused with exit 2 and one error line,
  // or, where the byte was slack (unused by HDF5), continues exactly as the intact checkpoint
  // does. A changed value that resumed into another chain would fail here. The refusal's former
  // leak is what the sanitizer job's LeakSanitizer checks.
  const fs::path dir = testing::fresh_output_dir("reliability_corrupt");
  const std::string intact = (dir / "intact.h5").string(), c = (dir / "c.h5").string();
  ASSERT_EQ(rbc("mc -n 150 --sweeps 20 -q --checkpoint " + intact).exit_code, 0);
  fs::copy_file(intact, c);
  const CommandRun clean = rbc("mc --resume " + c + " --sweeps 60 -q --json");
  ASSERT_EQ(clean.exit_code, 0) << clean.output;
  const json expected = chain_fields(clean.out);
  const auto size = fs::file_size(intact);
  std::mt19937 rng(36);
  int refused = 0, slack = 0;
  for (int trial = 0; trial < 41; ++trial) {
    fs::copy_file(intact, c, fs::copy_options::overwrite_existing);
    {
      std::fstream f(c, std::ios::in | std::ios::out | std::ios::binary);
      // Trial 0: 64 random bytes; then one byte at a time, changed to another value.
      for (int k = 0; k < (trial == 0 ? 64 : 1); ++k) {
        const auto at = static_cast<std::streamoff>(rng() % size);
        f.seekg(at);
        const int old = f.get();
        f.seekp(at);
        f.put(static_cast<char>((old + 1 + static_cast<int>(rng() % 255)) & 0xff));
      }
    }
    const CommandRun r = rbc("mc --resume " + c + " --sweeps 60 -q --json");
    SCOPED_TRACE("trial " + std::to_string(trial));
    ASSERT_TRUE(r.exit_code == 2 || r.exit_code == 0) << r.output;
    if (r.exit_code == 2) {
      ++refused;
      EXPECT_EQ(r.err.rfind("rbc: error: ", 0), 0u) << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_TRUE(r.out.empty()) << r.out;
    } else {
      ++slack;
      EXPECT_EQ(chain_fields(r.out), expected);
    }
  }
  RecordProperty("refused", refused);
  RecordProperty("slack", slack);
  // A value edited by hand (the sweep count of the chain) is refused, not resumed as written.
  fs::copy_file(intact, c, fs::copy_options::overwrite_existing);
  {
    const hid_t f = H5Fopen(c.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    const hid_t a = H5Aopen(f, "sweep", H5P_DEFAULT);
    ASSERT_GE(a, 0);
    const long long edited = 1000000000000000LL;
    EXPECT_GE(H5Awrite(a, H5T_NATIVE_LLONG, &edited), 0);
    H5Aclose(a);
    H5Fclose(f);
  }
  const CommandRun r = rbc("mc --resume " + c + " --sweeps 60 -q --json");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.err.find("checksum"), std::string::npos) << r.err;
}

TEST(ReliabilityRuntime, MonteCarloStartupContinuationScalesWithTheForce) {
  // The start-up continuation takes steps of at most 40 pN up to 200 pN, then geometric steps
  // of ratio at most 1.2 to the force: ceil(min(F, 200) / 40) + ceil(log(F / 200) / log 1.2)
  // solves, a length that grows with log F (2,000 pN: 5 + ceil(12.63) = 18; 1e6 pN:
  // 5 + ceil(46.72) = 52), checked here against that specification step by step.
  for (const double force_pN : {30.0, 200.0, 250.0, 2000.0, 1e6}) {
    const std::vector<double> f = mc_startup_forces(force_pN);
    const double linear_end_pN = std::min(force_pN, 200.0);
    const std::size_t expected =
        static_cast<std::size_t>(std::max(1.0, std::ceil(linear_end_pN / 40.0))) +
        (force_pN > 200.0
             ? static_cast<std::size_t>(std::ceil(std::log(force_pN / 200.0) / std::log(1.2)))
             : 0);
    ASSERT_EQ(f.size(), expected) << force_pN;
    EXPECT_EQ(f.back(), force_pN);
    double previous_pN = 0;
    for (const double step_pN : f) {
      EXPECT_GT(step_pN, previous_pN) << force_pN;
      if (step_pN <= 200.0 + 1e-9)
        EXPECT_LE(step_pN - previous_pN, 40.0 + 1e-9) << force_pN;
      else
        EXPECT_LE(step_pN / previous_pN, 1.2 * (1 + 1e-12)) << force_pN;
      previous_pN = step_pN;
    }
  }
  EXPECT_EQ(mc_startup_forces(2000.0).size(), 18u);
  EXPECT_EQ(mc_startup_forces(1e6).size(), 52u);
  // At the documented maximum force every step is reported on stderr and the run ends with a
  // verdict.
  const std::size_t n = mc_startup_forces(kMaxDiscreteForce_pN).size();
  const CommandRun r = rbc("mc --vertices 150 --force 500 --sweeps 20 --json");
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  const std::string step = "zero-temperature start-up: step ";
  std::size_t steps = 0;
  for (std::size_t at = r.output.find(step); at != std::string::npos;
       at = r.output.find(step, at + 1))
    ++steps;
  EXPECT_EQ(steps, n) << r.output;
  if (r.exit_code == 0) {
    const std::string last = "step " + std::to_string(n) + "/" + std::to_string(n) + " at 500.0";
    EXPECT_NE(r.output.find(last), std::string::npos) << r.output;
  } else {  // not converged: the residual in scientific notation
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.err, m, std::regex(R"(residual ([0-9]\.[0-9]+e[+-][0-9]+))")))
        << r.err;
    EXPECT_GT(std::stod(m[1].str()), 0.0) << r.err;
  }
}

TEST(ReliabilityRuntime, ModuliPatchSizeIsCappedAtWhatTheCellProblemSolvesInSeconds) {
  // Case 31: --cells 200 (the former maximum) did not finish; the maximum is now the size the
  // cell problem is measured to solve in seconds (kMaxHexagonalPatchCells = 100, 3.4 s CPU).
  const CommandRun r = rbc("moduli --cells 200 --json");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--cells 200"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[0, 100]"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("200"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace rbc
