// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// What the `rbc infer --resume` tests share (tests/app/test_infer_resume.cpp for TMCMC,
// tests/app/test_laplace_is_resume.cpp for laplace-is): a small data file, runs stopped by a
// signal at a progress line, and the comparison of two runs' posterior outputs, number for
// number. The signal at a progress line (signal_at_marker) and the checkpoint byte flip also
// serve tests/app/test_mc_forces_resume.cpp.
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
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "cli_run.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"

namespace rbc::testing::infer_resume {

namespace fs = std::filesystem;
using nlohmann::json;

inline std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The small data file (three forces), written into dir.
inline std::string data_file(const fs::path& dir) {
  const fs::path p = dir / "small.csv";
  std::ofstream(p) << "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                      "0,7.9,0.7,7.9,0.7\n30,10.5,0.9,5.7,0.6\n90,13.8,1.2,4.6,0.6\n";
  return p.string();
}

inline std::string joined(const std::vector<std::string>& args) {
  std::string s;
  for (const auto& a : args) s += (s.empty() ? "" : " ") + a;
  return s;
}

/// Exit code, or -signal for a child a signal ended.
inline int wait_child(pid_t pid) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

/// The pid of `rank` among the children of mpirun (OMPI_COMM_WORLD_RANK in its environment).
inline pid_t rank_pid(pid_t mpirun, int rank) {
  const std::string want = "OMPI_COMM_WORLD_RANK=" + std::to_string(rank);
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string stat = read_text(e.path() / "stat");
    const size_t close = stat.rfind(')');
    if (close == std::string::npos) continue;
    int ppid = 0;
    char state = 0;
    if (std::sscanf(stat.c_str() + close + 1, " %c %d", &state, &ppid) != 2 || ppid != mpirun)
      continue;
    const std::string env = read_text(e.path() / "environ");
    for (size_t b = 0; b < env.size();) {
      const size_t end = std::min(env.find('\0', b), env.size());
      if (env.compare(b, end - b, want) == 0) return static_cast<pid_t>(std::stoi(name));
      b = end + 1;
    }
  }
  return -1;
}

/// A run signalled at a progress line (signal_at_marker).
struct Signalled {
  bool seen = false;  ///< the marker appeared and the signal was sent
  int exit_code = 0;  ///< of the process (or of mpirun); -1000 when the marker never appeared
  std::string log;    ///< its stdout and stderr
};

/// Starts `[launcher] rbc ARGS` with stdout and stderr to `log`, waits until the log shows
/// `marker` (up to 120 s, or until the process ends), runs `at_marker` (if given), then sends
/// `sig` to the process (or, under mpirun, to the rank `rank`'s process), and waits for it. When
/// the rank's process is not found, no signal is sent and `seen` is false.
inline Signalled signal_at_marker(const std::vector<std::string>& args, const fs::path& log,
                                  const std::string& marker, int sig, int threads,
                                  const std::vector<std::string>& launcher = {}, int rank = -1,
                                  const std::function<void()>& at_marker = {}) {
  const pid_t pid = rbc::testing::spawn_rbc(args, log, threads, launcher);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  Signalled r;
  while (std::chrono::steady_clock::now() < deadline) {
    if (read_text(log).find(marker) != std::string::npos) {
      r.seen = true;
      break;
    }
    if (waitpid(pid, nullptr, WNOHANG) == pid) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (r.seen) {
    if (at_marker) at_marker();
    const pid_t target = rank >= 0 ? rank_pid(pid, rank) : pid;
    if (target > 0)  // never kill(-1, ...): that signals every process the user may signal
      kill(target, sig);
    else {
      r.seen = false;
      wait_child(pid);  // the run goes on to its end unsignalled
    }
  }
  r.exit_code = r.seen ? wait_child(pid) : -1000;
  r.log = read_text(log);
  return r;
}

struct Interrupted {
  int exit_code = 0;     ///< of the killed process (or of mpirun)
  bool mid_run = false;  ///< the signal arrived before the run finished
  std::string log;       ///< its stdout and stderr
};

/// Starts `rbc ARGS --out dir`, waits until its log shows `marker` (the checkpoint a progress
/// line reports is written before the line), then sends `sig` to the process (or, under mpirun,
/// to the rank `rank`'s process). If the run finishes first, the checkpoint copied the moment the
/// marker appeared replaces the final one and the outputs are removed, so the resume still
/// starts mid-way.
inline Interrupted interrupt_run(const std::vector<std::string>& args, const fs::path& dir,
                                 const std::string& marker, int sig, int threads,
                                 const std::vector<std::string>& launcher = {}, int rank = -1) {
  std::vector<std::string> a = args;
  a.insert(a.end(), {"--out", dir.string()});
  const fs::path snapshot = dir.string() + ".snapshot.h5";
  const Signalled s =
      signal_at_marker(a, dir.string() + ".log", marker, sig, threads, launcher, rank, [&] {
        fs::copy_file(dir / "checkpoint.h5", snapshot, fs::copy_options::overwrite_existing);
      });
  Interrupted r;
  r.exit_code = s.exit_code;
  r.log = s.log;
  r.mid_run = s.seen && !fs::exists(dir / "summary.json");
  if (s.seen && !r.mid_run) {  // finished first: resume from the marker's checkpoint instead
    for (const char* f : {"summary.json", "posterior_samples.csv", "posterior_samples.h5",
                          "predictive.csv", "corner_marginals.csv"})
      fs::remove(dir / f);
    fs::copy_file(snapshot, dir / "checkpoint.h5", fs::copy_options::overwrite_existing);
  }
  return r;
}

inline json summary_without_timing(const fs::path& dir) {
  json j = json::parse(read_text(dir / "summary.json"));
  j.erase("timing");
  j.erase("command");     // names the output directory and --resume
  j.erase("provenance");  // date, threads, command line
  if (j.contains("config"))
    for (const char* where : {"out", "resume", "threads", "quiet"}) j["config"].erase(where);
  return j;
}

/// Every posterior output of b equals a's, number for number (timing fields aside).
inline void expect_same_posterior(const fs::path& a, const fs::path& b) {
  SCOPED_TRACE(a.string() + " vs " + b.string());
  for (const char* f : {"posterior_samples.csv", "predictive.csv", "corner_marginals.csv"}) {
    const CsvTable x = read_csv((a / f).string()), y = read_csv((b / f).string());
    EXPECT_EQ(x.header, y.header) << f;
    ASSERT_FALSE(x.rows.empty()) << f;
    EXPECT_EQ(x.rows, y.rows) << f;  // exact: == on every double
  }
  EXPECT_EQ(summary_without_timing(a), summary_without_timing(b));
  std::vector<double> xs, ys;
  const H5File ha = H5File::open_read((a / "posterior_samples.h5").string());
  const H5File hb = H5File::open_read((b / "posterior_samples.h5").string());
  EXPECT_EQ(ha.read("samples", xs), hb.read("samples", ys));
  EXPECT_EQ(xs, ys);
  EXPECT_EQ(ha.read_attribute_double("log_evidence"), hb.read_attribute_double("log_evidence"));
}

/// A shell command (mpirun ...) with OpenMP at one passive thread; stderr into stdout.
inline rbc::testing::CliRun shell(const std::string& cmd) {
  rbc::testing::CliRun r;
  FILE* p = popen(("OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive " + cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) r.out.append(buf, n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = r.out;
  return r;
}

/// Changes one byte (the fourth) of `dataset`'s stored data in the HDF5 file at `path`, in place
/// and not through HDF5 (the dataset's offset from H5Dget_offset: contiguous storage). Returns
/// false if the dataset has no such offset.
inline bool flip_dataset_byte(const fs::path& path, const char* dataset) {
  haddr_t at = HADDR_UNDEF;
  {
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t d = H5Dopen2(f, dataset, H5P_DEFAULT);
    at = H5Dget_offset(d);
    H5Dclose(d);
    H5Fclose(f);
  }
  if (at == HADDR_UNDEF) return false;
  std::fstream g(path, std::ios::in | std::ios::out | std::ios::binary);
  g.seekg(static_cast<std::streamoff>(at) + 3);
  const char c = static_cast<char>(g.get() ^ 0x10);
  g.seekp(static_cast<std::streamoff>(at) + 3);
  g.put(c);
  return true;
}

}  // namespace rbc::testing::infer_resume
