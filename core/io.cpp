// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/io.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "core/h5file.hpp"

namespace rbc {
namespace fs = std::filesystem;

void ensure_output_directory(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec))
    throw std::invalid_argument("output directory '" + dir + "' cannot be created" +
                                (ec ? ": " + ec.message() : ""));
  if (access(dir.c_str(), W_OK) != 0)
    throw std::invalid_argument("output directory '" + dir + "' is not writable");
}

std::string temporary_path_for(const std::string& path) {
  const fs::path p(path);
  // Built by appending (GCC 12 warns falsely on "literal" + std::string&&, -Wrestrict).
  std::string name = ".";
  name += p.filename().string();
  name += ".partial-";
  name += std::to_string(getpid());
  return (p.parent_path() / name).string();
}

void throw_file_error(const std::string& path, const std::string& what, int err) {
  throw std::runtime_error(path + ": " + (what.empty() ? "" : what + ": ") + std::strerror(err));
}

void require_replaceable(const std::string& path) {
  const std::string kind = non_regular_kind(path);
  if (!kind.empty())
    throw std::runtime_error(path + ": is " + kind + ", expected a regular file or nothing");
}

namespace {
/// Closes fd when the scope ends (the error paths' close; the success path closes explicitly
/// and checks it).
struct FdCloser {
  int fd;
  ~FdCloser() {
    if (fd >= 0) ::close(fd);
  }
};

/// fsync(2) of the file at PATH; throws naming `shown`.
void fsync_path(const std::string& path, const std::string& shown) {
  FdCloser f{::open(path.c_str(), O_RDONLY | O_CLOEXEC)};
  if (f.fd < 0) throw_file_error(shown, "cannot reopen the temporary to sync it", errno);
  if (::fsync(f.fd) != 0) throw_file_error(shown, "", errno);
  const int fd = f.fd;
  f.fd = -1;
  if (::close(fd) != 0) throw_file_error(shown, "", errno);
}

/// Best-effort fsync of the directory holding PATH (makes the rename durable).
void fsync_parent(const std::string& path) {
  fs::path parent = fs::path(path).parent_path();
  if (parent.empty()) parent = ".";
  FdCloser d{::open(parent.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)};
  if (d.fd >= 0) (void)::fsync(d.fd);
}
}  // namespace

void commit_file(const std::string& tmp, const std::string& path) {
  try {
    fsync_path(tmp, path);
    require_replaceable(path);
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
      const int err = errno;
      // Another process may have put a directory or device there since the check above: the
      // error then names what is there, as the check does.
      require_replaceable(path);
      throw_file_error(path, "cannot move the finished file into place", err);
    }
  } catch (...) {
    ::unlink(tmp.c_str());
    throw;
  }
  fsync_parent(path);
}

void write_all(int fd, const void* bytes, std::size_t size, const std::string& shown) {
  const char* p = static_cast<const char*>(bytes);
  while (size > 0) {
    const ssize_t n = ::write(fd, p, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw_file_error(shown, "", errno);
    }
    if (n == 0) throw_file_error(shown, "", EIO);
    p += n;
    size -= static_cast<std::size_t>(n);
  }
}

void write_file_synced(const std::string& path, const void* bytes, std::size_t size,
                       const std::string& shown) {
  FdCloser f{::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0666)};
  if (f.fd < 0) throw_file_error(shown, "cannot create", errno);
  write_all(f.fd, bytes, size, shown);
  if (::fsync(f.fd) != 0) throw_file_error(shown, "", errno);
  const int fd = f.fd;
  f.fd = -1;
  if (::close(fd) != 0) throw_file_error(shown, "", errno);
}

namespace {

// The registry of live temporaries: fixed slots, lock-free, so that a signal handler can read it.
// A slot is free (0), busy (1: being filled or emptied by its owner) or live (2: `path` holds a
// temporary). Every change of a slot's path bumps `generation` while the slot is busy, so a
// reader that sees the same generation and state 2 before and after copying the path has an
// untorn copy (a seqlock). The characters are relaxed atomics, so the concurrent read is
// well-defined.
constexpr int kRegistrySlots = 64;
constexpr std::size_t kRegistryPathChars = 1024;
struct RegistrySlot {
  std::atomic<int> state{0};
  std::atomic<unsigned> generation{0};
  std::array<std::atomic<char>, kRegistryPathChars> path{};
};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<unsigned>::is_always_lock_free &&
              std::atomic<char>::is_always_lock_free);
// Constant-initialised (no guard variable), so a signal handler may read it at any time.
constinit std::array<RegistrySlot, kRegistrySlots> g_registry{};
std::array<RegistrySlot, kRegistrySlots>& registry() {
  return g_registry;
}

int register_temporary(const std::string& path) {
  if (path.size() + 1 > kRegistryPathChars) return -1;
  for (int k = 0; k < kRegistrySlots; ++k) {
    RegistrySlot& s = registry()[k];
    int expected = 0;
    if (!s.state.compare_exchange_strong(expected, 1)) continue;
    s.generation.fetch_add(1);
    for (std::size_t i = 0; i < path.size(); ++i)
      s.path[i].store(path[i], std::memory_order_relaxed);
    s.path[path.size()].store('\0', std::memory_order_relaxed);
    s.state.store(2);
    return k;
  }
  return -1;  // full: the guard still removes its file on unwinding
}

void unregister_temporary(int k) {
  if (k < 0) return;
  RegistrySlot& s = registry()[k];
  s.state.store(1);
  s.generation.fetch_add(1);
  s.state.store(0);
}

}  // namespace

TempFile::TempFile(std::string target)
    : target_(std::move(target)), tmp_(temporary_path_for(target_)) {
  slot_ = register_temporary(tmp_);
}

TempFile::~TempFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(tmp_, ec);
  }
  unregister_temporary(slot_);
}

void TempFile::commit() {
  commit_file(tmp_, target_);
  committed_ = true;
  unregister_temporary(slot_);
  slot_ = -1;
}

void remove_live_temporaries() noexcept {
  for (RegistrySlot& s : registry()) {
    const unsigned g = s.generation.load();
    if (s.state.load() != 2) continue;
    char copy[kRegistryPathChars];
    for (std::size_t i = 0; i < kRegistryPathChars; ++i) {
      copy[i] = s.path[i].load(std::memory_order_relaxed);
      if (copy[i] == '\0') break;
    }
    copy[kRegistryPathChars - 1] = '\0';
    if (s.state.load() == 2 && s.generation.load() == g) unlink(copy);
  }
}

int live_temporary_count() noexcept {
  int n = 0;
  for (const RegistrySlot& s : registry()) n += s.state.load() == 2 ? 1 : 0;
  return n;
}

void write_text_atomic(const std::string& path, const std::string& text) {
  require_replaceable(path);  // before any work on the file
  TempFile tmp(path);
  write_file_synced(tmp.path(), text.data(), text.size(), path);
  tmp.commit();
}

namespace {
constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
// The IEND chunk: length 0, type "IEND", CRC-32 of the type (0xAE426082).
constexpr unsigned char kPngEnd[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
}  // namespace

bool png_is_complete(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  unsigned char head[8] = {}, tail[12] = {};
  if (!in.read(reinterpret_cast<char*>(head), 8)) return false;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 8 + 12) return false;
  in.seekg(size - 12);
  if (!in.read(reinterpret_cast<char*>(tail), 12)) return false;
  return std::memcmp(head, kPngSignature, 8) == 0 && std::memcmp(tail, kPngEnd, 12) == 0;
}

bool png_bytes_are_complete(const std::string& bytes) {
  return bytes.size() >= 8 + 12 && std::memcmp(bytes.data(), kPngSignature, 8) == 0 &&
         std::memcmp(bytes.data() + bytes.size() - 12, kPngEnd, 12) == 0;
}

namespace {
/// Runs argv in `dir` with stdout and stderr into one pipe; returns (wait status, output), or
/// status -1 when the program cannot be started. fork + exec: the child only calls
/// async-signal-safe functions, and it starts with an empty signal mask (this process may block
/// SIGINT/SIGTERM in its threads; gnuplot must not inherit that).
std::pair<int, std::string> run_in_directory(const std::string& dir,
                                             const std::vector<std::string>& args) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) return {-1, std::strerror(errno)};
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    return {-1, std::strerror(err)};
  }
  if (pid == 0) {
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    ::dup2(fds[1], STDOUT_FILENO);
    ::dup2(fds[1], STDERR_FILENO);
    if (::chdir(dir.c_str()) != 0) _exit(126);
    ::execvp(argv[0], argv.data());
    _exit(127);
  }
  ::close(fds[1]);
  std::string output;
  std::array<char, 512> buf{};
  for (;;) {
    const ssize_t n = ::read(fds[0], buf.data(), buf.size());
    if (n > 0) {
      output.append(buf.data(), static_cast<std::size_t>(n));
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      break;
    }
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return {-1, std::strerror(errno)};
  return {status, output};
}

/// gnuplot's output on one line (no trailing newline, inner newlines as "; ").
std::string one_line(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (std::size_t k = 0; (k = s.find('\n', k)) != std::string::npos;) s.replace(k, 1, "; ");
  return s;
}
}  // namespace

void run_gnuplot_to_png(const std::string& dir, const std::string& script,
                        const std::string& png_path) {
  require_replaceable(png_path);
  TempFile tmp(png_path);  // removed if gnuplot fails or the run is interrupted
  const std::string tmp_name = fs::path(tmp.path()).filename().string();
  const auto [status, output] =
      run_in_directory(dir, {"gnuplot", "-e", "rbc_output='" + tmp_name + "'", script});
  if (status < 0)
    throw std::runtime_error(png_path + ": cannot run gnuplot (" + output +
                             "; is it installed? apt-get install gnuplot-nox)");
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127)
    throw std::runtime_error(png_path +
                             ": cannot run gnuplot (is it installed? apt-get install gnuplot-nox)");
  std::string cause;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    cause = WIFEXITED(status) ? "exit status " + std::to_string(WEXITSTATUS(status))
                              : "killed by signal " + std::to_string(WTERMSIG(status));
  else if (!png_is_complete(tmp.path()))
    cause = "exit status 0";
  // gnuplot does not report a failed write; a file system with no space left is the usual
  // cause, named when it is the case.
  if (struct statvfs fsinfo{};
      !cause.empty() && statvfs(dir.c_str(), &fsinfo) == 0 && fsinfo.f_bavail == 0)
    cause += ", " + std::string(std::strerror(ENOSPC));
  if (!cause.empty()) {
    const std::string said = one_line(output);
    throw std::runtime_error(png_path + ": incomplete PNG (gnuplot: " + cause +
                             (said.empty() ? "" : ", " + said) + ")");
  }
  tmp.commit();
}

void write_csv(const std::string& path, const CsvTable& t) {
  std::ostringstream s;
  s << std::setprecision(10);
  for (const auto& c : t.comments) s << "# " << c << "\n";
  const bool labelled = !t.label_header.empty();
  if (labelled && t.labels.size() != t.rows.size())
    throw std::logic_error(path + ": " + std::to_string(t.labels.size()) + " row labels for " +
                           std::to_string(t.rows.size()) + " rows");
  auto quoted = [](const std::string& text) {
    if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
    std::string q = "\"";
    for (char c : text) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
  };
  if (labelled) s << quoted(t.label_header) << (t.header.empty() ? "" : ",");
  for (size_t k = 0; k < t.header.size(); ++k) s << (k ? "," : "") << t.header[k];
  s << "\n";
  for (size_t r = 0; r < t.rows.size(); ++r) {
    const auto& row = t.rows[r];
    if (labelled) s << quoted(t.labels[r]) << (row.empty() ? "" : ",");
    for (size_t k = 0; k < row.size(); ++k) s << (k ? "," : "") << row[k];
    s << "\n";
  }
  write_text_atomic(path, s.str());
}

CsvTable read_csv(const std::string& path, CsvLabels labels) {
  check_csv_file(path);
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open CSV file '" + path + "'");
  return parse_csv(in, path, labels);
}

void write_mesh_snapshot(const std::string& base, const MeshSnapshot& snap) {
  const std::string h5_path = base + ".h5", xdmf_path = base + ".xdmf";
  const std::string h5_name = fs::path(h5_path).filename().string();
  const auto nv = static_cast<hsize_t>(snap.x.cols()), nf = static_cast<hsize_t>(snap.faces.cols());
  TempFile tmp(h5_path);
  {
    H5File f = H5File::create(tmp.path(), h5_path);
    // A 3 x N column-major matrix is an N x 3 row-major table: the layout XDMF expects.
    f.write("/mesh/positions_um", snap.x.data(), nv, 3);
    f.write("/mesh/faces", snap.faces.data(), nf, 3);
    for (const auto& [name, v] : snap.vertex_fields)
      f.write("/vertex/" + name, v.data(), static_cast<hsize_t>(v.size()), 1);
    for (const auto& [name, v] : snap.face_fields)
      f.write("/face/" + name, v.data(), static_cast<hsize_t>(v.size()), 1);
    for (const auto& [name, value] : snap.attributes) f.write_attribute(name, value);
    for (const auto& [name, value] : snap.text_attributes) f.write_attribute(name, value);
    f.close();
  }
  tmp.commit();
  std::ostringstream x;
  x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
    << "  <Grid Name=\"membrane\" GridType=\"Uniform\">\n"
    << "   <Topology TopologyType=\"Triangle\" NumberOfElements=\"" << nf << "\">\n"
    << "    <DataItem Dimensions=\"" << nf << " 3\" NumberType=\"Int\" Format=\"HDF\">" << h5_name
    << ":/mesh/faces</DataItem>\n   </Topology>\n"
    << "   <Geometry GeometryType=\"XYZ\">\n"
    << "    <DataItem Dimensions=\"" << nv
    << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name
    << ":/mesh/positions_um</DataItem>\n   </Geometry>\n";
  auto attribute = [&](const MeshField& fld, const char* centre, const char* group, hsize_t n) {
    x << "   <Attribute Name=\"" << fld.first << "\" AttributeType=\"Scalar\" Center=\"" << centre
      << "\">\n    <DataItem Dimensions=\"" << n << "\" NumberType=\"Float\" Precision=\"8\" "
      << "Format=\"HDF\">" << h5_name << ":/" << group << "/" << fld.first
      << "</DataItem>\n   </Attribute>\n";
  };
  for (const auto& f : snap.vertex_fields) attribute(f, "Node", "vertex", nv);
  for (const auto& f : snap.face_fields) attribute(f, "Cell", "face", nf);
  x << "  </Grid>\n </Domain>\n</Xdmf>\n";
  write_text_atomic(xdmf_path, x.str());
}

}  // namespace rbc
