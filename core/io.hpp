// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Files people open: CSV and JSON for numbers, HDF5 + XDMF for meshes and fields
// (ParaView reads the .xdmf). Every writer is atomic: it writes a temporary file in the
// target directory and renames it into place, so an interrupted run leaves no half file.
#include <Eigen/Core>
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

#include "core/mesh.hpp"

namespace rbc {

/// Creates the directory (and parents) if needed and checks it is writable; throws
/// std::invalid_argument naming the path otherwise.
void ensure_output_directory(const std::string& dir);

/// Temporary sibling path used by the atomic writers (same directory, hidden name
/// ".NAME.partial-PID").
std::string temporary_path_for(const std::string& path);
/// Renames tmp onto path (atomic on POSIX within one file system); throws on failure (and
/// removes tmp).
void commit_file(const std::string& tmp, const std::string& path);

/// Owns the temporary sibling of `target` an atomic writer fills: the temporary is removed when
/// the guard dies uncommitted (an exception, a cancelled run), so no ".partial" file survives
/// unwinding. While alive it is also listed in a process-wide registry of live temporaries that
/// remove_live_temporaries() empties, for a process that must stop without unwinding (a second
/// SIGINT/SIGTERM: see app/interrupt.hpp).
class TempFile {
 public:
  explicit TempFile(std::string target);
  ~TempFile();
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return tmp_; }       ///< the temporary to write
  const std::string& target() const { return target_; }  ///< where commit() puts it
  /// Renames the temporary onto the target; throws std::runtime_error naming the target.
  void commit();

 private:
  std::string target_, tmp_;
  int slot_ = -1;  ///< registry slot, -1 when not registered (path too long, registry full)
  bool committed_ = false;
};

/// Unlinks every temporary listed by a live TempFile. Async-signal-safe (lock-free atomics and
/// unlink(2) only), so a signal handler that must _exit may call it; a file being renamed at
/// that moment is either already in place (the unlink finds nothing) or removed.
void remove_live_temporaries() noexcept;
/// Number of temporaries currently registered (for tests).
int live_temporary_count() noexcept;

void write_text_atomic(const std::string& path, const std::string& text);

/// A numeric table with named columns; comment lines are written first as "# ...".
struct CsvTable {
  std::vector<std::string> comments;
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
};
void write_csv(const std::string& path, const CsvTable& table);
/// Reads a numeric CSV with '#' comment lines and one header line; throws
/// std::runtime_error naming the file and line for missing files or malformed values.
CsvTable read_csv(const std::string& path);
/// The same reader on a stream; `path` names the source in the messages (core/csv.cpp).
CsvTable parse_csv(std::istream& in, const std::string& path);
/// Throws std::runtime_error naming the file and the cause unless `path` can be opened as a
/// data file: "cannot open CSV file 'x': No such file or directory" (the system's text for the
/// error), "CSV file 'x' is a directory, expected a CSV file" (core/csv.cpp).
void check_csv_file(const std::string& path);

/// Named per-vertex or per-face scalar fields for a mesh snapshot.
using MeshField = std::pair<std::string, Eigen::VectorXd>;
struct MeshSnapshot {
  Positions x;  ///< 3 x N, um
  Faces faces;  ///< 3 x F
  std::vector<MeshField> vertex_fields;
  std::vector<MeshField> face_fields;
  std::vector<std::pair<std::string, double>> attributes;  ///< e.g. force_pN
};
/// Writes base + ".h5" and base + ".xdmf" (an XDMF 3 triangle grid ParaView opens).
void write_mesh_snapshot(const std::string& base_path, const MeshSnapshot& snapshot);

}  // namespace rbc
