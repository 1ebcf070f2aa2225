// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Runs the built `rbc` executable for a CLI test: exit code, stdout and stderr kept apart (JSON
// is read from stdout alone, so a library warning on stderr cannot break it), OpenMP pinned to
// the threads the caller names so that two processes compared bit for bit run alike.
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace rbc::testing {

struct CliRun {
  int exit_code = -1;  ///< the process's exit status, -1 if it did not exit normally
  std::string out;     ///< stdout
  std::string err;     ///< stderr
  /// stderr then stdout, for messages and failure reports (never parsed as JSON).
  std::string all() const { return err + out; }
};

/// `OMP_NUM_THREADS=threads build/rbc ARGS` (threads <= 0: the environment's setting); stderr
/// goes through a file of this process's own under build/test_output/cli_stderr.
inline CliRun run_rbc(const std::string& args, int threads = 1) {
  static std::atomic<int> calls{0};
  const std::filesystem::path dir =
      std::filesystem::path(RBC_BINARY_DIR) / "test_output" / "cli_stderr";
  std::filesystem::create_directories(dir);
  const std::filesystem::path err_path =
      dir / (std::to_string(getpid()) + "_" + std::to_string(calls++) + ".txt");
  const std::string env = threads > 0 ? "OMP_NUM_THREADS=" + std::to_string(threads) + " " : "";
  const std::string cmd =
      env + std::string(RBC_BINARY_DIR) + "/rbc " + args + " 2> '" + err_path.string() + "'";
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  for (size_t n; (n = std::fread(buf.data(), 1, buf.size(), p)) > 0;) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err_path);
  r.err.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  std::filesystem::remove(err_path);
  return r;
}

/// Starts `[launcher...] build/rbc ARGS` in the background (launcher: e.g. mpirun and its
/// options, looked up on PATH) with stdout and stderr to `log`, OMP_NUM_THREADS=threads
/// (threads <= 0: the environment's) and idle OpenMP threads sleeping; returns its pid.
inline pid_t spawn_rbc(const std::vector<std::string>& args, const std::filesystem::path& log,
                       int threads = 1, const std::vector<std::string>& launcher = {}) {
  std::vector<std::string> all = launcher;
  all.push_back(std::string(RBC_BINARY_DIR) + "/rbc");
  all.insert(all.end(), args.begin(), args.end());
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, 1);
      dup2(fd, 2);
      close(fd);
    }
    if (threads > 0) setenv("OMP_NUM_THREADS", std::to_string(threads).c_str(), 1);
    setenv("OMP_WAIT_POLICY", "passive", 1);
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

}  // namespace rbc::testing
