// SPDX-License-Identifier: GPL-3.0-or-later
#include "app/cli_util.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "core/io.hpp"
#include "core/validation.hpp"

namespace rbc::app {

namespace {
/// "--force" -> "force": the list's name in messages.
std::string list_noun(const std::string& option) {
  return option.rfind("--", 0) == 0 ? option.substr(2) : option;
}
}  // namespace

std::vector<double> parse_number_list(const std::string& text, const std::string& option,
                                      const std::string& example, bool allow_negative) {
  const std::string expected = std::string("expected a comma-separated list of finite numbers") +
                               (allow_negative ? "" : " >= 0") + " (e.g. " + example + ")";
  std::vector<double> out;
  if (text.find_first_not_of(" \t") == std::string::npos)
    throw std::invalid_argument(option + " '" + text + "': the " + list_noun(option) +
                                " list is empty; " + expected);
  // Every comma separates two items: "16," and "16,,38" name the empty item.
  for (std::size_t begin = 0, end = 0; end != std::string::npos; begin = end + 1) {
    end = text.find(',', begin);
    const std::string item = text.substr(begin, end == std::string::npos ? end : end - begin);
    if (item.find_first_not_of(" \t") == std::string::npos)
      throw std::invalid_argument(option + " '" + text + "': the " + list_noun(option) +
                                  " list has an empty item; " + expected);
    const std::optional<double> parsed = parse_number(item);
    if (!parsed)
      throw std::invalid_argument(option + " " + text + ": '" + item + "' is not a number; " +
                                  expected);
    const double v = *parsed;
    if (!std::isfinite(v) || (!allow_negative && v < 0))
      throw std::invalid_argument(option + " " + text + ": " + item + " is not allowed; " +
                                  expected);
    out.push_back(v + 0.0);  // -0 -> +0
  }
  return out;
}

std::vector<double> parse_force_list(const std::string& text) {
  return parse_number_list(text, "--force", "0,16,88 in pN", false);
}

ProgressSink stderr_progress(bool quiet, bool verbose) {
  if (quiet) return {};
  const auto start = std::chrono::steady_clock::now();
  return [start, verbose](const std::string& message) {
    if (!verbose && is_detail(message)) return;
    const double t =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::ostringstream line;  // its own format state: std::cerr's stays as it was
    line << "[" << std::fixed << std::setprecision(1) << std::setw(7) << t << " s] " << message
         << "\n";
    std::cerr << line.str() << std::flush;
  };
}

void add_verbose_flag(CLI::App* cmd, bool& verbose) {
  cmd->add_flag("--verbose,-v", verbose,
                "also the solver internals on stderr (Newton iterates, factorisations, "
                "preconditioner statistics)");
}

int naming_options(const OptionNames& names, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InvalidParameter& e) {
    const auto it = names.find(e.quantity());
    if (it == names.end()) throw;
    throw std::invalid_argument(it->second + " " + e.value() + ": " + e.quantity() + " must be " +
                                e.expectation());
  }
}

namespace {
template <class Int>
std::string check_integer(const std::string& text, Int lo, Int hi) {
  const std::string expected =
      "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  Int v{};
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);  // no blanks, no '+': as typed
  if (text.empty() || ec != std::errc() || ptr != end || v < lo || v > hi)
    return text + ": " + expected;
  return {};
}
}  // namespace

CLI::Validator integer_in(long long lo, long long hi) {
  return CLI::Validator([lo, hi](std::string& s) { return check_integer<long long>(s, lo, hi); },
                        "INT in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

CLI::Validator unsigned_integer() {
  return CLI::Validator(
      [](std::string& s) {
        return check_integer<unsigned long long>(s, 0ull,
                                                 std::numeric_limits<unsigned long long>::max());
      },
      "UINT64");
}

CLI::Validator nonempty_path() {
  return CLI::Validator(
      [](std::string& s) { return s.empty() ? std::string("'': expected a path") : std::string(); },
      "PATH");
}

namespace {
namespace fs = std::filesystem;

[[noreturn]] void refuse_path(const std::string& option, const std::string& path,
                              const std::string& what) {
  throw std::invalid_argument(option + " " + path + ": " + what);
}

/// lstat(2) of PATH: false when it does not exist; other failures (ENAMETOOLONG, ELOOP,
/// EACCES ...) are refused with their strerror text.
bool lstat_or_refuse(const std::string& path, struct stat& st, const std::string& option,
                     const std::string& shown) {
  if (lstat(path.c_str(), &st) == 0) return true;
  if (errno == ENOENT) return false;
  refuse_path(option, shown, std::strerror(errno));
}

/// Creates the directory if needed and proves it writable with a probe file.
void probe_writable(const std::string& dir, const std::string& option) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec))
    throw std::invalid_argument(option + " " + dir + ": cannot create the directory" +
                                (ec ? " (" + ec.message() + ")" : ""));
  const fs::path probe = fs::path(dir) / (".rbc-write-probe-" + std::to_string(getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  const int err = errno;
  if (fd < 0 || access(dir.c_str(), W_OK) != 0) {
    if (fd >= 0) ::close(fd);
    fs::remove(probe, ec);
    throw std::invalid_argument(option + " " + dir + ": the directory is not writable" +
                                (fd < 0 ? " (" + std::string(std::strerror(err)) + ")" : ""));
  }
  ::close(fd);
  fs::remove(probe, ec);
}

// The locks on the --out directories this process holds. Each lock's descriptor stays open for
// the process's whole lifetime: the exclusive flock lives exactly as long as the process, and
// the kernel releases it when the process ends however it ends (SIGKILL included), so a killed
// run never blocks its own resume. A process-wide resource, hence the one piece of global state
// here (guarded: commands may run on several threads). At a normal exit the lock file is
// removed while still locked, then closed; a file left by a killed process is taken over by the
// next run (lock_output_directory checks that the file it locked is still the one at the path).
struct HeldLock {
  std::string path;
  dev_t dev;
  ino_t ino;
  int fd;
};
struct HeldLocks {
  std::mutex mutex;
  std::vector<HeldLock> locks;
  ~HeldLocks() {
    for (const HeldLock& h : locks) {
      struct stat st {};
      if (stat(h.path.c_str(), &st) == 0 && st.st_dev == h.dev && st.st_ino == h.ino)
        ::unlink(h.path.c_str());
      ::close(h.fd);
    }
  }
};
HeldLocks& held_locks() {
  static HeldLocks locks;
  return locks;
}

/// The pid the holder wrote into the lock file ("" when not yet written).
std::string lock_holder(const std::string& lock_path) {
  for (int attempt = 0; attempt < 50; ++attempt) {  // the holder writes it right after locking
    std::ifstream in(lock_path);
    std::string pid;
    if (in >> pid && !pid.empty()) return pid;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return "";
}

/// Takes the exclusive lock on DIR/.rbc.lock (creating the file when `create`); returns false
/// when the file does not exist and !create. Refuses "in use by another rbc process (pid N)"
/// when another process holds it.
bool lock_output_directory(const std::string& dir, bool create, const std::string& option) {
  const std::string lock_path = (fs::path(dir) / kOutputLockName).string();
  for (int attempt = 0;; ++attempt) {
    const int fd =
        ::open(lock_path.c_str(), O_RDWR | O_CLOEXEC | O_NOFOLLOW | (create ? O_CREAT : 0), 0644);
    if (fd < 0) {
      if (errno == ENOENT && !create) return false;
      refuse_path(option, dir,
                  std::string("cannot create its lock file ") + kOutputLockName + ": " +
                      std::strerror(errno));
    }
    struct stat st {};
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
      ::close(fd);
      refuse_path(option, dir, std::string(kOutputLockName) + " is not a regular file");
    }
    HeldLocks& held = held_locks();
    const std::lock_guard<std::mutex> guard(held.mutex);
    for (const HeldLock& h : held.locks)
      if (h.dev == st.st_dev && h.ino == st.st_ino) {  // this process holds it already
        ::close(fd);
        return true;
      }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      ::close(fd);
      if (err == EWOULDBLOCK) {
        const std::string pid = lock_holder(lock_path);
        refuse_path(option, dir,
                    "in use by another rbc process" + (pid.empty() ? "" : " (pid " + pid + ")"));
      }
      refuse_path(option, dir, std::string("cannot lock it (") + std::strerror(err) + ")");
    }
    // The holder that ended may have removed the file between our open and our lock: the lock
    // counts only on the file still at the path (else another process may lock a new one).
    struct stat now {};
    if (stat(lock_path.c_str(), &now) != 0 || now.st_dev != st.st_dev || now.st_ino != st.st_ino) {
      ::close(fd);
      if (attempt < 100) continue;
      refuse_path(option, dir, "cannot lock it (its lock file keeps changing)");
    }
    const std::string pid = std::to_string(getpid()) + "\n";
    // Best effort: the pid only names the holder in another process's refusal.
    if (ftruncate(fd, 0) == 0) (void)!pwrite(fd, pid.data(), pid.size(), 0);
    held.locks.push_back({lock_path, st.st_dev, st.st_ino, fd});
    return true;
  }
}

/// Releases this process's lock on DIR (if held) and removes the lock file.
void unlock_output_directory(const std::string& dir) {
  struct stat st {};
  const std::string lock_path = (fs::path(dir) / kOutputLockName).string();
  if (stat(lock_path.c_str(), &st) != 0) return;
  HeldLocks& held = held_locks();
  const std::lock_guard<std::mutex> guard(held.mutex);
  for (auto it = held.locks.begin(); it != held.locks.end(); ++it)
    if (it->dev == st.st_dev && it->ino == st.st_ino) {
      ::unlink(lock_path.c_str());
      ::close(it->fd);
      held.locks.erase(it);
      return;
    }
}
}  // namespace

namespace {
/// Whether this process is a rank other than 0 of an MPI job (mpirun sets the rank in the
/// environment): every rank checks --out, rank 0 alone writes it and holds its lock.
bool mpi_worker_rank() {
  for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"})
    if (const char* rank = std::getenv(name)) return std::string(rank) != "0";
  return false;
}
}  // namespace

/// Whether a directory entry is a temporary (".NAME.partial-PID", core/io.hpp) of a process that
/// no longer runs: what a run killed by SIGKILL leaves mid-write.
bool is_stale_temporary(const fs::directory_entry& entry) {
  const std::string name = entry.path().filename().string();
  const auto mark = name.rfind(".partial-");
  if (name.empty() || name[0] != '.' || mark == std::string::npos) return false;
  const std::string digits = name.substr(mark + 9);
  if (digits.empty() || digits.size() > 9 ||
      digits.find_first_not_of("0123456789") != std::string::npos)
    return false;
  const pid_t pid = static_cast<pid_t>(std::stol(digits));
  std::error_code ec;
  return entry.is_regular_file(ec) && pid != getpid() && ::kill(pid, 0) != 0 && errno == ESRCH;
}

/// Removes the stale temporaries in `dir` (is_stale_temporary). Called with the directory's lock
/// held.
void remove_stale_temporaries(const std::string& dir) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (is_stale_temporary(*it)) {
      std::error_code ignored;
      fs::remove(it->path(), ignored);
    }
}

bool output_directory_is_empty(const std::string& dir) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().filename() != kOutputLockName && !is_stale_temporary(*it)) return false;
  return true;
}

void discard_empty_output_directory(const std::string& dir) {
  if (!output_directory_is_empty(dir)) return;
  unlock_output_directory(dir);
  std::error_code ec;
  fs::remove(dir, ec);
}

void prepare_output_directory(const std::string& dir, bool overwrite, bool allow_nonempty,
                              const std::string& option) {
  if (dir.empty()) throw std::invalid_argument(option + " '': expected a path");
  struct stat st {};
  const bool existed = lstat_or_refuse(dir, st, option, dir);
  if (existed && S_ISLNK(st.st_mode))
    refuse_path(option, dir, "is a symbolic link, expected a directory");
  if (existed && !S_ISDIR(st.st_mode)) {
    const std::string kind = non_regular_kind(dir);
    refuse_path(
        option, dir,
        "is " + (kind.empty() ? std::string("a regular file") : kind) + ", expected a directory");
  }
  // A directory another process holds is refused as in use, whatever it contains.
  const bool lock = !mpi_worker_rank();
  bool locked = lock && existed && lock_output_directory(dir, false, option);
  if (existed && !output_directory_is_empty(dir) && !overwrite && !allow_nonempty) {
    if (locked) unlock_output_directory(dir);
    refuse_path(option, dir,
                "the directory is not empty; choose another or pass --force-overwrite");
  }
  if (!existed) {
    // Parents first (each checked, so a symlink loop or a too long name is named).
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec || lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
      refuse_path(option, dir,
                  "cannot create the directory (" +
                      (ec ? std::string(std::strerror(ec.value())) : std::string("not created")) +
                      ")");
  }
  if (lock && !locked) lock_output_directory(dir, true, option);
  if (lock) remove_stale_temporaries(dir);  // what a killed run left; no live rbc writes here
  if (access(dir.c_str(), W_OK) != 0) refuse_path(option, dir, "the directory is not writable");
}

void check_output_file(const std::string& path, const std::string& option) {
  if (path.empty()) throw std::invalid_argument(option + " '': expected a path");
  struct stat st {};
  if (lstat_or_refuse(path, st, option, path) && !S_ISREG(st.st_mode))
    refuse_path(option, path,
                "is " + non_regular_kind(path) + ", expected a regular file or nothing");
  fs::path parent = fs::path(path).parent_path();
  if (parent.empty()) parent = ".";
  if (lstat_or_refuse(parent.string(), st, option, path) && !S_ISDIR(st.st_mode)) {
    // A symbolic link to a directory is a directory here (only the file itself must not be one).
    std::error_code ec;
    if (!fs::is_directory(parent, ec))
      refuse_path(option, path, "its directory " + parent.string() + " is not a directory");
  }
  probe_writable(parent.string(), option + " " + path + ": its directory");
}

void record_failed_manifest(const std::string& manifest_path,
                            const std::function<void()>& write_failed) noexcept {
  try {
    write_failed();
  } catch (...) {
    ::unlink(manifest_path.c_str());
  }
}

std::string number_tag(double value, int min_decimals) {
  return number_file_tag(value, min_decimals);
}

void require_distinct(const std::vector<double>& values, const std::string& option,
                      const std::string& text) {
  for (size_t i = 0; i < values.size(); ++i)
    for (size_t j = i + 1; j < values.size(); ++j)
      if (values[i] == values[j])
        throw std::invalid_argument(option + " " + text + ": values must be distinct, " +
                                    format_number(values[i]) +
                                    " appears twice and would write the same files twice");
}

}  // namespace rbc::app
