// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Files people open: CSV and JSON for numbers, HDF5 + XDMF for meshes and fields
// (ParaView reads the .xdmf), PNG through gnuplot. Every writer goes through one output layer:
// it refuses a target that exists and is not a regular file (a device, FIFO, socket,
// directory or symbolic link), writes a temporary file in the target directory, checks every
// write and the close, fsyncs the temporary, renames it into place and fsyncs the directory
// (best effort). On any failure the temporary is removed and a std::runtime_error names the
// file and the cause (strerror), so an interrupted or failed run leaves no half file.
#include <Eigen/Core>
#include <cstddef>
#include <iosfwd>
#include <string>
#include <string_view>
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
/// Fsyncs tmp, refuses a target that exists and is not a regular file, renames tmp onto path
/// (atomic on POSIX within one file system) and fsyncs the directory (best effort). Throws
/// std::runtime_error "PATH: <cause>" on failure, after removing tmp.
void commit_file(const std::string& tmp, const std::string& path);

/// What kind of file PATH is when it exists and is not a regular file ("a character device",
/// "a FIFO", "a socket", "a directory", "a symbolic link", "a block device"), as lstat(2) sees
/// it (a symbolic link is not followed); empty when PATH is a regular file or does not exist.
/// Throws std::runtime_error "PATH: <strerror>" when lstat fails for another reason than a
/// missing file (ENAMETOOLONG, ELOOP, EACCES ...).
std::string non_regular_kind(const std::string& path);
/// Throws std::runtime_error "PATH: is <kind>, expected a regular file or nothing" when PATH
/// exists and is not a regular file (see non_regular_kind).
void require_replaceable(const std::string& path);

/// "PATH: <what>: <strerror(err)>" as a std::runtime_error (what may be empty).
[[noreturn]] void throw_file_error(const std::string& path, const std::string& what, int err);

/// Writes all of `bytes` to the open descriptor fd (retrying short writes and EINTR); throws
/// std::runtime_error naming `shown` and strerror(errno) on failure.
void write_all(int fd, const void* bytes, std::size_t size, const std::string& shown);
/// Creates (truncating) `path`, writes `bytes`, fsyncs and closes it, every step checked; the
/// error names `shown` (the user's file name when `path` is a temporary). Does not rename.
void write_file_synced(const std::string& path, const void* bytes, std::size_t size,
                       const std::string& shown);

/// A number for file names that reads back (strtod) as the same double, so distinct values
/// never share a name: fixed notation with at least min_decimals decimals and as many more as
/// needed (16.01 -> "16.01", 16 -> "16.0" with min_decimals 1); when fixed notation would need
/// more than 20 decimals or 24 characters (1e-300, 5e-324, 1e300), the shortest scientific
/// form that round-trips ("1e-300"). Non-finite values give "inf", "-inf" or "nan".
std::string number_file_tag(double value, int min_decimals);

/// Whether FILE holds a complete PNG: the 8-byte PNG signature at the start and an IEND chunk
/// (length 0, type "IEND", its CRC) as the last 12 bytes. False for a missing or short file.
bool png_is_complete(const std::string& path);
/// The same test on a PNG held in memory (e.g. one a drawing process wrote to a pipe).
bool png_bytes_are_complete(const std::string& bytes);

/// Runs `gnuplot -e "rbc_output='TMP'" SCRIPT` in directory `dir` (SCRIPT a file name in dir,
/// already written; it must `set output rbc_output`), where TMP is the temporary sibling of
/// `png_path` (a path in dir). The PNG counts as written only when gnuplot exits 0 AND the
/// temporary reads back as a complete PNG (png_is_complete); then it is committed
/// (commit_file). Otherwise throws std::runtime_error "PNG_PATH: incomplete PNG (gnuplot:
/// <its output or exit status>)", or "cannot run gnuplot ..." when gnuplot is missing, and
/// leaves no temporary.
void run_gnuplot_to_png(const std::string& dir, const std::string& script,
                        const std::string& png_path);

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
  /// Fsyncs the temporary and renames it onto the target (commit_file); throws
  /// std::runtime_error naming the target and the cause.
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

/// Writes `text` to PATH atomically (temporary, checked writes, fsync, rename); throws
/// std::runtime_error "PATH: <strerror>" on failure and leaves no temporary.
void write_text_atomic(const std::string& path, const std::string& text);

/// A numeric table with named columns; comment lines are written first as "# ...". A table may
/// name its rows in a leading text column (label_header, one label per row; quoted as RFC 4180
/// asks where a label holds a comma, a quote or a line break); read_csv reads numeric tables.
struct CsvTable {
  std::vector<std::string> comments;
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  std::string label_header = {};
  std::vector<std::string> labels = {};
};
void write_csv(const std::string& path, const CsvTable& table);
/// Text taken from a file, fit for a one-line message: printable ASCII as it is, every other
/// byte (NUL, control characters, non-ASCII) as \xNN; at most 60 bytes shown, then "...".
std::string printable(std::string_view text);
/// Position of `word` in `text` at or after `from` where it stands as a word of its own (no ASCII
/// letter right before or after it), or std::string_view::npos.
std::size_t find_word(std::string_view text, std::string_view word, std::size_t from = 0);

/// Whether a CSV file names its rows in a leading text column (CsvTable::labels).
enum class CsvLabels { none, first_column };
/// Reads a numeric CSV with '#' comment lines and one header line (with CsvLabels::first_column,
/// the first column is the rows' labels, RFC 4180 quoting undone); throws std::runtime_error
/// naming the file and line for missing files or malformed values.
CsvTable read_csv(const std::string& path, CsvLabels labels = CsvLabels::none);
/// The same reader on a stream; `path` names the source in the messages (core/csv.cpp).
CsvTable parse_csv(std::istream& in, const std::string& path, CsvLabels labels = CsvLabels::none);
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
  /// Text attributes of the file, e.g. what produced it (rbc_version, rbc_command_line).
  std::vector<std::pair<std::string, std::string>> text_attributes = {};
};
/// Writes base + ".h5" and base + ".xdmf" (an XDMF 3 triangle grid ParaView opens).
void write_mesh_snapshot(const std::string& base_path, const MeshSnapshot& snapshot);

}  // namespace rbc
