// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/io.hpp"

#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdio>
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
  if (!fs::is_directory(dir))
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

void commit_file(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw std::runtime_error("cannot move finished file into place at '" + path + "'");
  }
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
  TempFile tmp(path);
  {
    std::ofstream out(tmp.path(), std::ios::binary);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write '" + path + "'");
  }
  tmp.commit();
}

void write_csv(const std::string& path, const CsvTable& t) {
  std::ostringstream s;
  s << std::setprecision(10);
  for (const auto& c : t.comments) s << "# " << c << "\n";
  for (size_t k = 0; k < t.header.size(); ++k) s << (k ? "," : "") << t.header[k];
  s << "\n";
  for (const auto& row : t.rows) {
    for (size_t k = 0; k < row.size(); ++k) s << (k ? "," : "") << row[k];
    s << "\n";
  }
  write_text_atomic(path, s.str());
}

CsvTable read_csv(const std::string& path) {
  check_csv_file(path);
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open CSV file '" + path + "'");
  return parse_csv(in, path);
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
