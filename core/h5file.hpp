// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Minimal RAII access to HDF5 files: 2-D double/int datasets and scalar attributes. Every HDF5
// identifier (file, dataset, dataspace, attribute, datatype, group) is owned by an object that
// closes it, on error paths too.
// All errors (missing file, not HDF5, missing dataset) throw std::runtime_error with the
// file and object named; HDF5's own error printing is silenced.
// A file created for writing is built in memory (HDF5's core driver, no backing store) and
// written to disk by close() through the output layer's checked writes (core/io.hpp: every
// write checked, fsync, close checked), so a full disk is reported with its cause and never
// leaves HDF5 holding a file it failed to flush (whose library shutdown at exit() would
// crash). Files are opened with the "strong" close degree: closing the file closes every
// object still open in it.
// Every file written here is sealed: its first 512 bytes (an HDF5 user block, which HDF5 and
// the tools that read HDF5 skip) hold the FNV-1a hash and length of the rest of the file. A file
// opened for reading whose seal does not match is refused before HDF5 parses any of it, so a
// damaged file never reaches HDF5's parser (which is not hardened against corrupt metadata).
#include <hdf5.h>

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace rbc {

/// What H5File::open_read asks of a file's seal (the hash of its bytes in its user block).
enum class H5Seal {
  if_present,  ///< a sealed file must match its seal; a file without one is read as it is
  required,    ///< the file must carry a matching seal (files rbc writes itself: checkpoints)
};

/// An open HDF5 file. Owns the handle; closes on destruction.
class H5File {
 public:
  /// Creates (truncating) a file for writing: `path` is created on disk at once (so a
  /// directory that cannot take it is reported here), its contents are written by close().
  /// Errors name `name_in_errors` if given (the user's file name when `path` is the temporary
  /// an atomic writer fills) and the cause (strerror).
  static H5File create(const std::string& path, const std::string& name_in_errors = "");
  /// Opens an existing file read-only; throws if missing, not HDF5, or its seal does not match
  /// its bytes (or, with H5Seal::required, it has no seal).
  static H5File open_read(const std::string& path, H5Seal seal = H5Seal::if_present);
  H5File(H5File&& other) noexcept;
  H5File& operator=(H5File&&) = delete;
  H5File(const H5File&) = delete;
  /// Closes quietly. A file created for writing and not closed with close() is written when
  /// the object dies outside unwinding; if that write fails (or the object dies while an
  /// exception unwinds) the file on disk is removed, so an atomic writer's commit of it fails
  /// loudly instead of committing a half file. Call close() to see the cause.
  ~H5File();
  /// Writes the file (if created for writing) and closes it, releasing every HDF5 object and
  /// the descriptor on every path; throws std::runtime_error "FILE: <cause>" on failure.
  void close();

  /// Row-major 2-D dataset of shape rows x cols from `data` (rows*cols values). Parent
  /// groups in `name` ("a/b/c") are created as needed.
  void write(const std::string& name, const double* data, hsize_t rows, hsize_t cols);
  void write(const std::string& name, const int* data, hsize_t rows, hsize_t cols);
  void write(const std::string& name, const unsigned long long* data, hsize_t rows, hsize_t cols);
  void write_attribute(const std::string& name, double value);
  void write_attribute(const std::string& name, long long value);
  void write_attribute(const std::string& name, const std::string& value);

  bool has(const std::string& name) const;
  /// Whether the file's root carries the attribute `name`.
  bool has_attribute(const std::string& name) const;
  /// Reads a 2-D (or 1-D, as n x 1) dataset into a row-major buffer; returns its shape.
  std::pair<hsize_t, hsize_t> read(const std::string& name, std::vector<double>& out) const;
  std::pair<hsize_t, hsize_t> read(const std::string& name, std::vector<int>& out) const;
  std::pair<hsize_t, hsize_t> read(const std::string& name,
                                   std::vector<unsigned long long>& out) const;
  double read_attribute_double(const std::string& name) const;
  long long read_attribute_int(const std::string& name) const;
  std::string read_attribute_string(const std::string& name) const;

  /// FNV-1a checksum (core/fnv1a.hpp) of the file's contents: every dataset's path, shape and
  /// bytes as stored, and every attribute of the root group, name and bytes as stored, each in
  /// name order; the root attribute named `skip_attribute` is left out (the one holding the
  /// checksum). Equal contents give equal checksums whatever the file's layout; a changed value
  /// changes it. Throws std::runtime_error naming the file if an object cannot be read.
  std::uint64_t content_checksum(const std::string& skip_attribute) const;

  const std::string& path() const { return path_; }

 private:
  H5File(hid_t id, std::string path) : id_(id), path_(std::move(path)) {}
  /// Writes the in-memory image to fd_ (checked), then releases everything; throws on failure.
  void write_image_and_close();
  /// Closes every HDF5 object of the file and the file itself, and the descriptor; noexcept.
  void release() noexcept;
  void ensure_parent_groups(const std::string& name);
  void write_raw(const std::string& name, hid_t type, const void* data, hsize_t rows, hsize_t cols);
  std::pair<hsize_t, hsize_t> read_raw(const std::string& name, hid_t type,
                                       std::function<void*(size_t)> alloc) const;
  hid_t id_ = -1;
  std::string path_;
  int fd_ = -1;                 ///< the file on disk a created file is written to, -1 when reading
  std::string disk_path_;       ///< its path (removed when the write fails)
  int uncaught_at_create_ = 0;  ///< std::uncaught_exceptions() when created
};

}  // namespace rbc
