// SPDX-License-Identifier: GPL-3.0-or-later
// The output layer seen from the command line: an --out that names a device, FIFO, socket,
// directory or symbolic link is refused before any work and left as it was; a full disk (made
// by tests/support/enospc_shim.c, or a small tmpfs when the machine allows mounting one) ends
// each writing command with exit 2 and one error line naming the file and "No space left on
// device", no temporary left and no run.json saying "running"; a PNG that gnuplot leaves
// incomplete is an error; two processes never share an --out, and a run killed with SIGKILL
// resumes into its own --out; distinct tiny forces write distinct files.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "cli_run.hpp"
#include "core/h5file.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;
using testing::CliRun;
using testing::fresh_output_dir;
using testing::run_rbc;

std::string quoted(const fs::path& p) {
  return "'" + p.string() + "'";
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Sets environment variables for the runs of one scope (the child processes inherit them).
class ScopedEnv {
 public:
  void set(const std::string& name, const std::string& value) {
    const char* old = std::getenv(name.c_str());
    saved_.push_back({name, old ? std::optional<std::string>(old) : std::nullopt});
    setenv(name.c_str(), value.c_str(), 1);
  }
  ~ScopedEnv() {
    for (auto it = saved_.rbegin(); it != saved_.rend(); ++it) {
      if (it->second)
        setenv(it->first.c_str(), it->second->c_str(), 1);
      else
        unsetenv(it->first.c_str());
    }
  }

 private:
  std::vector<std::pair<std::string, std::optional<std::string>>> saved_;
};

/// Every file under dir whose name marks a temporary.
std::vector<std::string> temporaries_under(const fs::path& dir) {
  std::vector<std::string> found;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().filename().string().find(".partial") != std::string::npos)
      found.push_back(it->path().string());
  return found;
}

/// The checks every full-disk failure must pass: exit 2 (not a crash), one error line that
/// names a file under `dir` and the cause, no temporary, no run.json saying "running".
void expect_clean_full_disk_failure(const CliRun& r, const fs::path& dir, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(r.exit_code, 2) << r.all();
  const std::string err = r.err;
  std::size_t lines = 0;
  for (char c : err) lines += c == '\n' ? 1 : 0;
  EXPECT_EQ(lines, 1u) << err;
  EXPECT_EQ(err.rfind("rbc: error: ", 0), 0u) << err;
  EXPECT_NE(err.find("No space left on device"), std::string::npos) << err;
  EXPECT_NE(err.find(dir.string()), std::string::npos) << "the file is not named: " << err;
  EXPECT_EQ(err.find("filesystem error"), std::string::npos) << err;
  EXPECT_TRUE(temporaries_under(dir).empty()) << temporaries_under(dir).front();
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().filename() == "run.json") {
      const nlohmann::json j = nlohmann::json::parse(read_all(it->path()), nullptr, false);
      ASSERT_TRUE(j.is_object()) << it->path() << " is not complete JSON";
      EXPECT_NE(j.value("status", ""), "running") << it->path();
      EXPECT_EQ(j.value("status", ""), "failed") << it->path();
      EXPECT_NE(j.value("reason", "").find("No space left on device"), std::string::npos);
    }
}

// ---- special files, symbolic links, bad paths -------------------------------------------

TEST(OutputLayer, AFifoAtOutIsRefusedBeforeAnyWorkAndLeftAlone) {
  const fs::path dir = fresh_output_dir("output_layer_fifo");
  const fs::path fifo = dir / "fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0666), 0);
  const CliRun r = run_rbc("psi --order 2 --curve uniaxial --out " + quoted(fifo));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("rbc: error: --out " + fifo.string() +
                       ": is a FIFO, expected a regular file or nothing"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(fifo)));
  EXPECT_TRUE(temporaries_under(dir).empty());
}

TEST(OutputLayer, ACharacterDeviceAtOutIsRefusedAndLeftAlone) {
  const fs::path dir = fresh_output_dir("output_layer_device");
  const fs::path node = dir / "node";
  if (mknod(node.c_str(), S_IFCHR | 0666, makedev(1, 7)) != 0)
    GTEST_SKIP() << "mknod needs root (" << std::strerror(errno) << ")";
  const CliRun r = run_rbc("psi --order 2 --curve uniaxial --out " + quoted(node));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("--out " + node.string() +
                       ": is a character device, expected a regular file or nothing"),
            std::string::npos)
      << r.err;
  struct stat st {};
  ASSERT_EQ(lstat(node.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

TEST(OutputLayer, SymbolicLinksAtOutAreRefusedNotReplaced) {
  const fs::path dir = fresh_output_dir("output_layer_symlink");
  const fs::path target = dir / "target.csv", link = dir / "link.csv";
  { std::ofstream(target) << "keep\n"; }
  fs::create_symlink(target, link);
  CliRun r = run_rbc("psi --order 2 --curve uniaxial --out " + quoted(link));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("is a symbolic link, expected a regular file or nothing"), std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(link)));
  EXPECT_EQ(read_all(target), "keep\n");
  // A symbolic link to a directory as an output directory.
  fs::create_directory(dir / "real");
  fs::create_directory_symlink(dir / "real", dir / "dirlink");
  r = run_rbc("mesh --vertices 300 --out " + quoted(dir / "dirlink"));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("is a symbolic link, expected a directory"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_empty(dir / "real"));
}

TEST(OutputLayer, AnEmptyOutIsRefused) {
  for (const std::string cmd : {"psi --order 2 --curve uniaxial", "stretch --vertices 300",
                                "mc --vertices 300 --sweeps 10", "mesh --vertices 300"}) {
    const CliRun r = run_rbc(cmd + " --out ''");
    EXPECT_EQ(r.exit_code, 2) << cmd << "\n" << r.all();
    EXPECT_NE(r.err.find("--out '': expected a path"), std::string::npos) << cmd << "\n" << r.err;
  }
}

TEST(OutputLayer, FileSystemErrorsAreNamedByTheirCause) {
  const fs::path dir = fresh_output_dir("output_layer_fs_errors");
  fs::create_symlink("loop", dir / "loop");  // a link to itself
  CliRun r = run_rbc("psi --order 2 --curve uniaxial --out " + quoted(dir / "loop" / "x.csv"));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("Too many levels of symbolic links"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("filesystem error"), std::string::npos) << r.err;
  const std::string long_name(300, 'a');
  r = run_rbc("psi --order 2 --curve uniaxial --out " + quoted(dir / (long_name + ".csv")));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("File name too long"), std::string::npos) << r.err;
  r = run_rbc("mesh --vertices 300 --out " + quoted(dir / long_name));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("--out " + (dir / long_name).string() + ": File name too long"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("filesystem error"), std::string::npos) << r.err;
}

// ---- a full disk -------------------------------------------------------------------------

/// The four writing commands of the full-disk checks, writing under `dir`.
struct FullDiskCase {
  std::string what, args;
};
std::vector<FullDiskCase> full_disk_cases(const fs::path& dir) {
  return {
      {"mc checkpoint", "mc --vertices 300 --sweeps 2000 -q --checkpoint " + quoted(dir / "c.h5") +
                            " --checkpoint-every 10"},
      {"mc --out",
       "mc --vertices 300 --sweeps 200 -q --snapshot-every 50 --out " + quoted(dir / "mc")},
      {"stretch continuum",
       "stretch --model continuum --elements 500 --force 0,16,38 -q --out " + quoted(dir / "o")},
      {"dynamics",
       "dynamics --model discrete --scene release --force 50 -n 300 --duration 0.02 "
       "--dt 0.002 -q --out " +
           quoted(dir / "d")},
  };
}

/// Whether build/rbc runs with the shim preloaded (a sanitizer build refuses a preload).
bool shim_usable() {
  ScopedEnv env;
  env.set("LD_PRELOAD", RBC_ENOSPC_SHIM);
  const CliRun r = run_rbc("--version");
  return r.exit_code == 0;
}

TEST(OutputLayer, AFullDiskEndsEveryWriterCleanly) {
  if (!shim_usable()) GTEST_SKIP() << "build/rbc does not run with an LD_PRELOAD library";
  // Byte budgets: nothing at all, and a budget that runs out in the middle of the outputs.
  for (const long long budget : {0LL, 40000LL}) {
    const fs::path dir =
        fs::canonical(fresh_output_dir("output_layer_enospc_" + std::to_string(budget)));
    for (const FullDiskCase& c : full_disk_cases(dir)) {
      ScopedEnv env;
      env.set("LD_PRELOAD", RBC_ENOSPC_SHIM);
      env.set("RBC_ENOSPC_DIR", dir.string());
      env.set("RBC_ENOSPC_AFTER", std::to_string(budget));
      const CliRun r = run_rbc(c.args);
      expect_clean_full_disk_failure(r, dir, c.what + ", budget " + std::to_string(budget));
    }
  }
}

/// A tmpfs of 200 kB mounted on `dir` for one test (root only); unmounted when done.
class SmallTmpfs {
 public:
  explicit SmallTmpfs(const fs::path& dir) : dir_(dir) {
    mounted_ = mount("tmpfs", dir.c_str(), "tmpfs", 0, "size=200k") == 0;
    error_ = mounted_ ? "" : std::strerror(errno);
  }
  ~SmallTmpfs() {
    if (mounted_) umount2(dir_.c_str(), MNT_DETACH);
  }
  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }
  /// Empties the file system and fills it with `kb` kB.
  void fill(int kb) const {
    for (const auto& e : fs::directory_iterator(dir_)) fs::remove_all(e.path());
    std::ofstream(dir_ / "filler", std::ios::binary) << std::string(std::size_t(kb) * 1024, '\0');
  }

 private:
  fs::path dir_;
  bool mounted_ = false;
  std::string error_;
};

TEST(OutputLayer, AFullTmpfsEndsEveryWriterCleanly) {
  const fs::path dir = fs::canonical(fresh_output_dir("output_layer_tmpfs"));
  const SmallTmpfs full(dir);
  if (!full.mounted()) GTEST_SKIP() << "cannot mount a tmpfs here: " << full.error();
  std::vector<FullDiskCase> cases = full_disk_cases(dir);
  cases.push_back({"fig7 PNG", "fig7 --method discrete:300 -q --data " +
                                   quoted(fs::path(RBC_SOURCE_DIR) / "data") + " --out " +
                                   quoted(dir / "f")});
  for (const FullDiskCase& c : cases) {
    full.fill(160);  // 40 kB left: the small files fit, a PNG or a shape does not
    const CliRun r = run_rbc(c.args);
    std::error_code ec;
    fs::remove(dir / "filler", ec);  // room for nothing else to fail while checking
    expect_clean_full_disk_failure(r, dir, c.what);
  }
}

/// A stand-in for gnuplot that writes a PNG cut short (the signature and nothing else) and
/// exits 0, as gnuplot does on a full disk.
fs::path fake_gnuplot(const fs::path& dir) {
  const fs::path bin = dir / "bin";
  fs::create_directories(bin);
  std::ofstream(bin / "gnuplot")
      << "#!/bin/sh\n"
         "# gnuplot -e \"rbc_output='NAME'\" SCRIPT\n"
         "name=$(printf '%s' \"$2\" | sed \"s/^rbc_output='//; s/'$//\")\n"
         "printf '\\211PNG\\r\\n\\032\\n' > \"$name\"\n"
         "exit 0\n";
  fs::permissions(bin / "gnuplot", fs::perms::owner_all);
  return bin;
}

TEST(OutputLayer, AnIncompletePngIsAnError) {
  const fs::path dir = fresh_output_dir("output_layer_png");
  const fs::path bin = fake_gnuplot(dir);
  ScopedEnv env;
  env.set("PATH", bin.string() + ":" + std::getenv("PATH"));
  const fs::path out = dir / "o";
  const CliRun r = run_rbc("fig7 --method discrete:300 -q --data " +
                           quoted(fs::path(RBC_SOURCE_DIR) / "data") + " --out " + quoted(out));
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("rbc: error: " + (out / "fig7.png").string() +
                       ": incomplete PNG (gnuplot: exit status 0"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out / "fig7.png"));
  EXPECT_TRUE(temporaries_under(out).empty());
}

// ---- exclusive --out, kill and resume ---------------------------------------------------

/// `rbc args...` in the background on one OpenMP thread (cli_run.hpp).
pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  return testing::spawn_rbc(args, log, 1);
}

/// Waits until `path` exists while the child runs; false if the child ended first.
bool wait_for_file(const fs::path& path, pid_t child) {
  for (;;) {
    if (fs::exists(path)) return true;
    int status = 0;
    if (waitpid(child, &status, WNOHANG) == child) return fs::exists(path);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

TEST(OutputLayer, OneOutDirectoryOneProcessAndAKilledRunResumesIntoIt) {
  const fs::path dir = fresh_output_dir("output_layer_lock");
  const fs::path out = dir / "o", checkpoint = dir / "c.h5";
  const pid_t first =
      spawn({"mc", "--vertices", "300", "--sweeps", "100000000", "-q", "--checkpoint",
             checkpoint.string(), "--checkpoint-every", "10", "--out", out.string()},
            dir / "first.log");
  ASSERT_GT(first, 0);
  // run.json is written after the lock is taken: from then on the directory is held.
  ASSERT_TRUE(wait_for_file(out / "run.json", first)) << read_all(dir / "first.log");
  const CliRun second = run_rbc("stretch --vertices 300 --force 16 -q --out " + quoted(out));
  EXPECT_EQ(second.exit_code, 2) << second.all();
  EXPECT_NE(second.err.find("--out " + out.string() + ": in use by another rbc process (pid " +
                            std::to_string(first) + ")"),
            std::string::npos)
      << second.err;
  const CliRun forced =
      run_rbc("stretch --vertices 300 --force 16 -q --force-overwrite --out " + quoted(out));
  EXPECT_EQ(forced.exit_code, 2) << "--force-overwrite does not take a directory in use";
  // Kill the first run once it has checkpointed; its lock dies with it.
  ASSERT_TRUE(wait_for_file(checkpoint, first)) << read_all(dir / "first.log");
  ASSERT_EQ(kill(first, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(waitpid(first, &status, 0), first);
  ASSERT_TRUE(WIFSIGNALED(status));
  const long long at = H5File::open_read(checkpoint.string()).read_attribute_int("sweep");
  const CliRun resumed =
      run_rbc("mc --sweeps " + std::to_string(at + 20) + " -q --resume " + quoted(checkpoint) +
              " --checkpoint " + quoted(checkpoint) + " --out " + quoted(out));
  EXPECT_EQ(resumed.exit_code, 0) << resumed.all();
  const nlohmann::json run = nlohmann::json::parse(read_all(out / "run.json"), nullptr, false);
  EXPECT_EQ(run.value("status", ""), "finished") << run.dump();
  EXPECT_EQ(run.value("sweeps_done", -1LL), at + 20);
  // An unrelated run into that directory is still refused as not empty.
  const CliRun other = run_rbc("mc --vertices 300 --sweeps 10 -q --out " + quoted(out));
  EXPECT_EQ(other.exit_code, 2);
  EXPECT_NE(other.err.find("not empty"), std::string::npos) << other.err;
}

/// What a run whose checkpoint path became a directory leaves: exit 2, one error line naming
/// the path and what was expected, a manifest saying "failed" for that reason, the directory
/// untouched and no temporary.
void expect_checkpoint_directory_failure(int exit_code, const fs::path& dir,
                                         const fs::path& log_file, const fs::path& out,
                                         const fs::path& checkpoint) {
  EXPECT_EQ(exit_code, 2);
  const std::string log = read_all(log_file);
  EXPECT_NE(log.find("rbc: error: " + checkpoint.string() +
                     ": is a directory, expected a regular file or nothing"),
            std::string::npos)
      << log;
  const nlohmann::json j = nlohmann::json::parse(read_all(out / "run.json"), nullptr, false);
  EXPECT_EQ(j.value("status", ""), "failed") << j.dump();
  EXPECT_NE(j.value("reason", "").find("is a directory"), std::string::npos) << j.dump();
  EXPECT_TRUE(fs::is_directory(fs::symlink_status(checkpoint)));
  EXPECT_TRUE(temporaries_under(dir).empty());
}

TEST(OutputLayer, ACheckpointReplacedByADirectoryFailsTheRunAndItsManifestSaysSo) {
  const fs::path dir = fresh_output_dir("output_layer_checkpoint_dir");
  const fs::path out = dir / "o", checkpoint = dir / "c.h5";
  const pid_t run = spawn({"mc", "--vertices", "300", "--sweeps", "100000000", "-q", "--checkpoint",
                           checkpoint.string(), "--checkpoint-every", "10", "--out", out.string()},
                          dir / "run.log");
  ASSERT_GT(run, 0);
  ASSERT_TRUE(wait_for_file(checkpoint, run)) << read_all(dir / "run.log");
  // Replace the checkpoint by a directory (the run may rename a new one in between: retry).
  std::error_code ec;
  while (!fs::is_directory(fs::symlink_status(checkpoint))) {
    fs::remove(checkpoint, ec);
    fs::create_directory(checkpoint, ec);
  }
  int status = 0;
  ASSERT_EQ(waitpid(run, &status, 0), run);
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status);
  expect_checkpoint_directory_failure(WEXITSTATUS(status), dir, dir / "run.log", out, checkpoint);
}

// The same replacement at the one moment the live race above rarely hits: after the writer
// checked the target and before it renames its temporary there (tests/support/
// rename_race_shim.c). The error is the same as at any other moment.
TEST(OutputLayer, ACheckpointReplacedJustBeforeItsRenameFailsWithTheSameError) {
  if (!shim_usable()) GTEST_SKIP() << "build/rbc does not run with an LD_PRELOAD library";
  const fs::path dir = fs::canonical(fresh_output_dir("output_layer_checkpoint_race"));
  const fs::path out = dir / "o", checkpoint = dir / "c.h5";
  ScopedEnv env;
  env.set("LD_PRELOAD", RBC_RENAME_RACE_SHIM);
  env.set("RBC_RACE_DIRECTORY_AT", checkpoint.string());
  const CliRun r = run_rbc("mc --vertices 300 --sweeps 100 -q --checkpoint " + quoted(checkpoint) +
                           " --checkpoint-every 10 --out " + quoted(out));
  std::ofstream(dir / "run.log") << r.all();
  expect_checkpoint_directory_failure(r.exit_code, dir, dir / "run.log", out, checkpoint);
}

TEST(OutputLayer, TheLockFileIsHiddenAndDoesNotMakeTheDirectoryNonEmpty) {
  const fs::path dir = fresh_output_dir("output_layer_lock_file");
  const fs::path out = dir / "o";
  fs::create_directories(out);
  std::ofstream(out / ".rbc.lock") << "12345\n";  // left by an earlier run, not held
  const CliRun r = run_rbc("mesh --vertices 300 --out " + quoted(out));
  EXPECT_EQ(r.exit_code, 0) << r.all();
  EXPECT_TRUE(fs::exists(out / "rest_shape.h5"));
}

// The PID of a process that has ended: a child that exited and was reaped. A literal PID can
// belong to a running process on the machine that runs the test (low PIDs do in a container just
// started); the kernel hands PIDs out in increasing order, so this one is not reused within the
// test.
pid_t ended_pid() {
  const pid_t child = fork();
  if (child == 0) _exit(0);
  int status = 0;
  waitpid(child, &status, 0);
  return child;
}

TEST(OutputLayer, TemporariesAKilledRunLeftAreRemovedByTheNextRunOnTheDirectory) {
  const fs::path out = fresh_output_dir("output_layer_stale_temporaries") / "o";
  fs::create_directories(out);
  // What SIGKILL leaves behind mid-write: temporaries of processes that no longer run.
  const std::string dead_a = std::to_string(ended_pid()), dead_b = std::to_string(ended_pid());
  std::ofstream(out / (".shape_16.0pN.h5.partial-" + dead_a)) << "half";
  std::ofstream(out / (".run.json.partial-" + dead_b)) << "{";
  std::ofstream(out / "notes.partial-1") << "not a temporary: kept";  // no leading dot
  // A temporary of a process that still runs (this test) is being written: kept.
  const fs::path live = out / (".other.h5.partial-" + std::to_string(getpid()));
  std::ofstream(live) << "in progress";
  const CliRun r = run_rbc("mesh --vertices 300 --force-overwrite --out " + quoted(out));
  EXPECT_EQ(r.exit_code, 0) << r.all();
  std::vector<std::string> kept{live.string(), (out / "notes.partial-1").string()};
  std::sort(kept.begin(), kept.end());
  std::vector<std::string> found = temporaries_under(out);
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, kept) << r.all();
  // A directory holding only stale temporaries counts as empty.
  const fs::path second = fresh_output_dir("output_layer_stale_only") / "o";
  fs::create_directories(second);
  std::ofstream(second / (".mesh_quality.json.partial-" + std::to_string(ended_pid()))) << "{";
  EXPECT_EQ(run_rbc("mesh --vertices 300 --out " + quoted(second)).exit_code, 0);
}

// ---- file names -------------------------------------------------------------------------

TEST(OutputLayer, DistinctTinyForcesWriteDistinctShapeFiles) {
  const fs::path out = fresh_output_dir("output_layer_tiny") / "o";
  const CliRun r = run_rbc("stretch --vertices 300 --force 1e-300,1e-299 -q --out " + quoted(out));
  EXPECT_EQ(r.exit_code, 0) << r.all();
  EXPECT_TRUE(fs::exists(out / "shape_1e-300pN.h5"));
  EXPECT_TRUE(fs::exists(out / "shape_1e-299pN.h5"));
  const nlohmann::json run = nlohmann::json::parse(read_all(out / "run.json"), nullptr, false);
  ASSERT_EQ(run["forces_complete"].size(), 2u) << run.dump();
  EXPECT_NE(run["forces_complete"][0]["shape_h5"], run["forces_complete"][1]["shape_h5"]);
}

}  // namespace
}  // namespace rbc
