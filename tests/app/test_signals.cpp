// SPDX-License-Identifier: GPL-3.0-or-later
// SIGINT/SIGTERM on their own thread (app/interrupt.hpp): every thread but the signal thread
// blocks them; a SIGTERM that arrives while METIS orders a sparse analysis (METIS installs its
// own SIGTERM handler meanwhile) ends the run with 143 and complete outputs; METIS's own error
// signal (a SIGTERM it raises at its thread) ends it with exit 2 and one error line; every
// command ends 130/143 on a signal mid-run. The signal inside the ordering comes from an
// LD_PRELOAD library around METIS_NodeND (tests/support/metis_shim.c), so the executable carries
// no test hook.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "test_output.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kRbc = std::string(RBC_BINARY_DIR) + "/rbc";

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Starts `rbc args...` (working directory `cwd`) with stdout to `out` and stderr to `err`,
/// one OpenMP thread unless `env` says otherwise; `env` entries (NAME=VALUE) are added.
pid_t spawn(const std::vector<std::string>& args, const fs::path& cwd, const fs::path& out,
            const fs::path& err, const std::vector<std::string>& env = {}) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int o = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int e = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (o < 0 || e < 0 || chdir(cwd.c_str()) != 0) _exit(126);
    dup2(o, 1);
    dup2(e, 2);
    close(o);
    close(e);
    setenv("OMP_NUM_THREADS", "1", 1);
    setenv("OMP_WAIT_POLICY", "passive", 1);
    for (const auto& kv : env) putenv(const_cast<char*>(kv.c_str()));
    std::vector<char*> argv{const_cast<char*>(kRbc.c_str())};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(kRbc.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

constexpr int kHung = -1000;

/// Exit code of a child, or -signal if a signal killed it; a child still running after two
/// minutes (a hang: the runs here take seconds) is killed and kHung returned.
int wait_for(pid_t pid) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
  int status = 0;
  while (true) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return kHung;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

/// Whether the child has not ended yet (it is not reaped: wait_for still reads its status).
bool running(pid_t pid) {
  siginfo_t info{};
  return waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 &&
         info.si_pid == 0;
}

/// The signal mask "SigBlk" of a /proc status file (0 if unreadable).
unsigned long long blocked_mask(const fs::path& status) {
  std::ifstream in(status);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("SigBlk:", 0) == 0) return std::stoull(line.substr(7), nullptr, 16);
  return 0;
}

constexpr unsigned long long kIntTerm = (1ull << (SIGINT - 1)) | (1ull << (SIGTERM - 1));

/// Waits until the child's main thread blocks SIGINT and SIGTERM (main() has begun: a signal is
/// then the command's to handle); false if it ended first.
bool wait_until_started(pid_t pid) {
  const fs::path status = fs::path("/proc") / std::to_string(pid) / "status";
  while (running(pid)) {
    if ((blocked_mask(status) & kIntTerm) == kIntTerm) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return false;
}

/// Files under `dir` whose name marks an atomic writer's temporary.
std::vector<std::string> temporaries_in(const fs::path& dir) {
  std::vector<std::string> t;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".partial") != std::string::npos)
      t.push_back(e.path().string());
  return t;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);)
    if (!l.empty()) lines.push_back(l);
  return lines;
}

/// One run of `rbc` in a fresh directory, optionally with the METIS shim (RBC_METIS_SHIM=mode).
struct SignalRun {
  fs::path dir;
  int code = kHung;
  std::string out, err;
};

SignalRun run_rbc_in(const std::string& name, const std::vector<std::string>& args,
                     const std::string& shim_mode, int threads = 1) {
  SignalRun r;
  r.dir = testing::fresh_output_dir("signals/" + name);
  std::vector<std::string> env{"RBC_METIS_SHIM_LOG=1",
                               "OMP_NUM_THREADS=" + std::to_string(threads)};
  if (!shim_mode.empty()) {
    env.push_back(std::string("LD_PRELOAD=") + RBC_METIS_SHIM);
    env.push_back("RBC_METIS_SHIM=" + shim_mode);
    // Under AddressSanitizer (.ci/sanitize.sh) a preloaded library comes before its runtime.
    const char* asan = std::getenv("ASAN_OPTIONS");
    env.push_back(std::string("ASAN_OPTIONS=") + (asan ? std::string(asan) + ":" : "") +
                  "verify_asan_link_order=0");
  }
  const pid_t pid = spawn(args, r.dir, r.dir / "stdout.txt", r.dir / "stderr.txt", env);
  r.code = wait_for(pid);
  r.out = slurp(r.dir / "stdout.txt");
  r.err = slurp(r.dir / "stderr.txt");
  return r;
}

const std::vector<std::string> kStretch{"stretch", "--vertices", "300", "--force",
                                        "0,16,38", "--out",      "o",   "-q"};

TEST(Signals, TheShimReachesCholmodsOrdering) {
  // The premise of the tests below: CHOLMOD calls METIS_NodeND through the dynamic linker, so the
  // shim's definition runs (it logs each call), and with no mode it changes nothing.
  const SignalRun r = run_rbc_in("shim_pass_through", kStretch, "none:1");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("metis_shim: call 1"), std::string::npos) << r.err;
  EXPECT_EQ(json::parse(slurp(r.dir / "o" / "run.json")).at("status"), "finished");
}

TEST(Signals, SigtermDuringAnOrderingEnds143WithCompleteOutputs) {
  // kill(getpid(), SIGTERM) from inside METIS_NodeND while METIS's own SIGTERM handler is
  // installed. Taken by the signal thread, it stops the run at its next poll.
  for (const auto& [mode, sig] :
       {std::pair<std::string, int>{"term:1", SIGTERM}, {"int:1", SIGINT}}) {
    SCOPED_TRACE(mode);
    const SignalRun r = run_rbc_in("ordering_" + mode.substr(0, mode.find(':')), kStretch, mode);
    ASSERT_NE(r.code, kHung);
    EXPECT_EQ(r.code, 128 + sig) << r.err;
    EXPECT_EQ(r.err.find("drew no random number"), std::string::npos) << "the shim never fired";
    EXPECT_NE(
        r.err.find(std::string("rbc: interrupted by ") + (sig == SIGINT ? "SIGINT" : "SIGTERM")),
        std::string::npos)
        << r.err;
    EXPECT_EQ(temporaries_in(r.dir), std::vector<std::string>{});
    const json j = json::parse(slurp(r.dir / "o" / "run.json"));
    EXPECT_EQ(j.at("status"), "interrupted") << j.dump();
    EXPECT_FALSE(j.at("complete").get<bool>());
    EXPECT_NE(j.at("reason").get<std::string>().find(sig == SIGINT ? "SIGINT" : "SIGTERM"),
              std::string::npos)
        << j.dump();
    EXPECT_FALSE(fs::exists(r.dir / "o" / "stretch.csv"));
    int shapes = 0;
    for (const auto& e : fs::directory_iterator(r.dir / "o"))
      shapes += e.path().extension() == ".h5";
    EXPECT_EQ(shapes, static_cast<int>(j.at("forces_complete").size())) << j.dump();
  }
}

TEST(Signals, MetisErrorSignalEndsWithExit2AndOneErrorLine) {
  // METIS reports an internal error by raise(SIGTERM): thread-directed, so with SIGTERM blocked it
  // stays pending on the analysing thread. The analysis consumes it and fails; the command
  // neither hangs nor reports an interrupt.
  for (const std::string mode : {"error:1", "error-return:1"}) {
    SCOPED_TRACE(mode);
    const SignalRun r = run_rbc_in("metis_" + mode.substr(0, mode.find(':')), kStretch, mode);
    ASSERT_NE(r.code, kHung);
    EXPECT_EQ(r.code, 2) << r.err;
    std::vector<std::string> errors;
    for (const auto& l : lines_of(r.err))
      if (l.rfind("metis_shim:", 0) != 0) errors.push_back(l);
    ASSERT_EQ(errors.size(), 1u) << r.err;
    EXPECT_EQ(errors[0].rfind("rbc: error: ", 0), 0u) << errors[0];
    EXPECT_NE(errors[0].find("ordering (METIS) failed"), std::string::npos) << errors[0];
    EXPECT_EQ(temporaries_in(r.dir), std::vector<std::string>{});
    EXPECT_EQ(json::parse(slurp(r.dir / "o" / "run.json")).at("status"), "failed");
  }
}

TEST(Signals, EveryThreadButTheSignalThreadBlocksSigintAndSigterm) {
  // Blocked in main() before any other thread exists, so OpenMP's workers inherit the mask; the
  // one thread that does not block them (sigwait unblocks what it waits for) is not main().
  const fs::path dir = testing::fresh_output_dir("signals/thread_masks");
  // A stretch: its Hessian assembly runs on the OpenMP threads (mc samples on one thread).
  const pid_t pid = spawn({"stretch", "--vertices", "8000", "--force", "0,50,100,150,200", "-q"},
                          dir, dir / "stdout.txt", dir / "stderr.txt", {"OMP_NUM_THREADS=2"});
  const fs::path tasks = fs::path("/proc") / std::to_string(pid) / "task";
  std::vector<std::pair<int, unsigned long long>> masks;
  auto unblocked = [&masks] {
    int n = 0;
    for (const auto& m : masks) n += (m.second & kIntTerm) != kIntTerm;
    return n;
  };
  // Sampled until the three threads (main, signals, OpenMP) are seen with the signal thread
  // inside sigwait(); a wrong mask keeps the loop going to its end (a hang guard, 60 s).
  for (int tries = 0; tries < 6000 && (masks.size() < 3 || unblocked() != 1); ++tries) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    masks.clear();
    std::error_code ec;
    for (const auto& t : fs::directory_iterator(tasks, ec))
      masks.emplace_back(std::stoi(t.path().filename().string()),
                         blocked_mask(t.path() / "status"));
  }
  kill(pid, SIGTERM);
  EXPECT_EQ(wait_for(pid), 128 + SIGTERM) << slurp(dir / "stderr.txt");
  ASSERT_GE(masks.size(), 3u) << "the run never had three threads";
  for (const auto& [tid, mask] : masks) {
    if ((mask & kIntTerm) != kIntTerm) {
      EXPECT_NE(tid, pid) << "main() does not block them";
    }
  }
  EXPECT_EQ(unblocked(), 1) << masks.size() << " threads";
}

/// A sub-command run that the signal reaches mid-run: through the shim inside its first ordering
/// (commands that factorise a sparse matrix), else once its output directory exists (long runs).
/// psi and moduli take milliseconds and order nothing: no signal reaches them mid-run reliably.
struct CommandCase {
  std::string name;
  std::vector<std::string> args;
  bool orders;
};

TEST(Signals, EveryCommandEnds130Or143MidRun) {
  const std::string data =
      std::string(RBC_SOURCE_DIR) + "/data/suresh2005_healthy_optical_tweezers.csv";
  const std::vector<CommandCase> cases{
      {"mesh", {"mesh", "--vertices", "40000", "--out", "o"}, false},
      {"stretch", {"stretch", "--vertices", "300", "--force", "0,16,38", "--out", "o"}, true},
      {"relax", {"relax", "--elements", "500", "--out", "o"}, true},
      {"mc", {"mc", "--vertices", "300", "--sweeps", "1000000", "--out", "o"}, false},
      {"dynamics",
       {"dynamics", "--model", "discrete", "--scene", "release", "--force", "50", "-n", "300",
        "--duration", "0.02", "--dt", "0.002", "--out", "o"},
       true},
      {"fig7", {"fig7", "--method", "discrete:150", "--force", "0,100,200", "--out", "o"}, true},
      {"tradeoff",
       {"tradeoff", "--force", "50", "--vertices", "150,300", "--elements", "200", "--orders", "2",
        "--mc-vertices", "150", "--out", "o"},
       true},
      {"infer",
       {"infer", "--data-file", data, "--params", "persistence", "--method", "continuum:2:200",
        "--sampler", "tmcmc", "--samples", "20", "--out", "o"},
       true},
      {"report", {"report", "--quick", "--out", "o"}, true},
      {"stability", {"stability", "--vertices", "100", "--elements", "200", "--out", "o"}, true},
      {"bench", {"bench", "stretch", "--benchmark_filter=discrete/stretch_88pN/500"}, true},
  };
  for (const auto& c : cases)
    for (const int sig : {SIGTERM, SIGINT}) {
      const std::string tag = c.name + (sig == SIGINT ? "_int" : "_term");
      SCOPED_TRACE(tag);
      SignalRun r;
      if (c.orders) {
        r = run_rbc_in("command_" + tag, c.args, sig == SIGINT ? "int:1" : "term:1");
        EXPECT_EQ(r.err.find("drew no random number"), std::string::npos) << "the shim never fired";
        EXPECT_NE(r.err.find("metis_shim: call 1"), std::string::npos) << "no ordering: " << r.err;
      } else {
        r.dir = testing::fresh_output_dir("signals/command_" + tag);
        const pid_t pid = spawn(c.args, r.dir, r.dir / "stdout.txt", r.dir / "stderr.txt");
        // Past start-up and the checks of the arguments: the output directory exists.
        EXPECT_TRUE(wait_until_started(pid));
        while (!fs::exists(r.dir / "o") && running(pid))
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
        EXPECT_TRUE(fs::exists(r.dir / "o")) << "ended before its work began";
        kill(pid, sig);
        r.code = wait_for(pid);
        r.err = slurp(r.dir / "stderr.txt");
      }
      ASSERT_NE(r.code, kHung);
      EXPECT_EQ(r.code, 128 + sig) << r.err;
      EXPECT_NE(
          r.err.find(std::string("rbc: interrupted by ") + (sig == SIGINT ? "SIGINT" : "SIGTERM")),
          std::string::npos)
          << r.err;
      EXPECT_EQ(temporaries_in(r.dir), std::vector<std::string>{});
    }
}

TEST(Signals, UnknownCommandIsNamed) {
  const fs::path dir = testing::fresh_output_dir("signals/unknown_command");
  const pid_t pid = spawn({"frobnicate", "--x", "1"}, dir, dir / "stdout.txt", dir / "stderr.txt");
  EXPECT_EQ(wait_for(pid), 2);
  const auto lines = lines_of(slurp(dir / "stderr.txt"));
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].rfind("rbc: error: unknown command 'frobnicate' (expected one of ", 0), 0u)
      << lines[0];
  for (const char* name : {"mesh", "stretch", "relax", "mc", "dynamics", "moduli", "psi", "fig7",
                           "tradeoff", "infer", "report", "stability", "bench"})
    EXPECT_NE(lines[0].find(name), std::string::npos) << name;
}

TEST(Signals, BenchFilterThatSelectsNothingIsRefused) {
  for (const auto& [filter, expected] :
       {std::pair<std::string, std::string>{"no_such_benchmark", "matches no benchmark"},
        {"(", "not a valid regular expression"}}) {
    SCOPED_TRACE(filter);
    const SignalRun r =
        run_rbc_in("bench_filter", {"bench", "stretch", "--benchmark_filter=" + filter}, "");
    EXPECT_EQ(r.code, 2) << r.err << r.out;
    const auto lines = lines_of(r.err);
    ASSERT_EQ(lines.size(), 1u) << r.err;
    EXPECT_EQ(lines[0].rfind("rbc: error: --benchmark_filter " + filter + ": " + expected, 0), 0u)
        << lines[0];
    EXPECT_EQ(r.out, "");  // nothing ran
  }
  const SignalRun r =
      run_rbc_in("bench_filter", {"bench", "stretch", "--benchmark_filter=nope"}, "");
  EXPECT_NE(r.err.find("available: discrete/energy_gradient, discrete/preconditioner_apply, "
                       "discrete/stretch_88pN)"),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace rbc
