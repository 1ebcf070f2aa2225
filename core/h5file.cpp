// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/h5file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "core/fnv1a.hpp"
#include "core/io.hpp"

namespace rbc {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("HDF5 file '" + path + "': " + what);
}

struct Silence {  // HDF5 prints its error stack by default; we report errors ourselves.
  Silence() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }
};
const Silence& silence() {
  static const Silence s;
  return s;
}

/// Owns one HDF5 object identifier (dataset, dataspace, attribute, datatype, group) and closes
/// it with its own H5?close on every path out of a scope, error paths included.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

}  // namespace

namespace {
/// Removes the file a failed write left at PATH, only if it is a regular file (never a device
/// or anything else the path may name).
void remove_written_file(const std::string& path) noexcept {
  struct stat st {};
  if (lstat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) ::unlink(path.c_str());
}

/// A file-access property list with the strong close degree (H5Fclose closes every object
/// still open in the file), and for a created file the in-memory core driver without backing
/// store (close() writes the image through the output layer).
class AccessList {
 public:
  explicit AccessList(bool in_memory) : id_(H5Pcreate(H5P_FILE_ACCESS)) {
    if (id_ < 0) return;
    if (H5Pset_fclose_degree(id_, H5F_CLOSE_STRONG) < 0 ||
        (in_memory && H5Pset_fapl_core(id_, std::size_t(1) << 20, 0) < 0)) {
      H5Pclose(id_);
      id_ = -1;
    }
  }
  ~AccessList() {
    if (id_ >= 0) H5Pclose(id_);
  }
  AccessList(const AccessList&) = delete;
  AccessList& operator=(const AccessList&) = delete;
  hid_t get() const { return id_; }

 private:
  hid_t id_;
};

/// The seal in a file's user block: this text, then "fnv1a64 HEX16 bytes N\n" (the hash and length
/// of the bytes after the block), zero padded.
constexpr std::size_t kUserBlockBytes = 512;
constexpr std::string_view kSealMagic = "rbc sealed HDF5 file\n";

/// The user block that seals `image` (the HDF5 image of a file created with a kUserBlockBytes user
/// block, which H5Fget_file_image leaves out: the file on disk is this block, then the image).
std::vector<char> seal_block(const std::vector<char>& image) {
  Fnv1a hash;
  hash.add(image.data(), image.size());
  char line[96];
  const int n = std::snprintf(line, sizeof line, "fnv1a64 %016llx bytes %zu\n",
                              static_cast<unsigned long long>(hash.h), image.size());
  std::vector<char> block(kUserBlockBytes, '\0');
  std::copy(kSealMagic.begin(), kSealMagic.end(), block.begin());
  std::copy(line, line + n, block.begin() + static_cast<std::ptrdiff_t>(kSealMagic.size()));
  return block;
}

/// Checks the seal of the file at `path` against its bytes; throws naming the file if it does
/// not match, or if the file has none and `seal` requires one.
void check_seal(const std::string& path, H5Seal seal) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) fail(path, "is missing or not an HDF5 file");
  if (S_ISDIR(st.st_mode)) fail(path, "is a directory, not an HDF5 file");
  if (!S_ISREG(st.st_mode)) fail(path, "is not a regular file (a FIFO, device or socket)");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "is missing or not an HDF5 file");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.eof() && in.fail()) fail(path, "cannot be read");
  const bool has_seal =
      bytes.size() >= kUserBlockBytes && bytes.compare(0, kSealMagic.size(), kSealMagic) == 0;
  if (!has_seal) {
    if (seal == H5Seal::required)
      fail(path,
           "has no seal (the checksum rbc writes in its first 512 bytes): it was not "
           "written by rbc, or it is corrupt");
    return;
  }
  unsigned long long stored_hash = 0;
  std::size_t stored_size = 0;
  const std::string line = bytes.substr(kSealMagic.size(), 64);
  if (std::sscanf(line.c_str(), "fnv1a64 %16llx bytes %zu", &stored_hash, &stored_size) != 2)
    fail(path, "is corrupt: its seal cannot be read");
  Fnv1a actual;
  actual.add(bytes.data() + kUserBlockBytes, bytes.size() - kUserBlockBytes);
  if (stored_size != bytes.size() - kUserBlockBytes)
    fail(path, "is corrupt: it has " + std::to_string(bytes.size()) +
                   " bytes where its seal says " + std::to_string(stored_size + kUserBlockBytes));
  if (actual.h != stored_hash)
    fail(path, "is corrupt: its bytes do not match the checksum sealed with them");
}

}  // namespace

H5File H5File::create(const std::string& path, const std::string& name_in_errors) {
  silence();
  const std::string shown = name_in_errors.empty() ? path : name_in_errors;
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0666);
  if (fd < 0) throw_file_error(shown, "cannot create", errno);
  const AccessList fapl(true);
  const hid_t fcpl = H5Pcreate(H5P_FILE_CREATE);
  const bool fcpl_ok = fcpl >= 0 && H5Pset_userblock(fcpl, kUserBlockBytes) >= 0;
  const hid_t id =
      fapl.get() < 0 || !fcpl_ok ? -1 : H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl, fapl.get());
  if (fcpl >= 0) H5Pclose(fcpl);
  if (id < 0) {
    ::close(fd);
    remove_written_file(path);
    fail(shown, "cannot be created in memory (HDF5 error)");
  }
  H5File f(id, shown);
  f.fd_ = fd;
  f.disk_path_ = path;
  f.uncaught_at_create_ = std::uncaught_exceptions();
  return f;
}

H5File H5File::open_read(const std::string& path, H5Seal seal) {
  silence();
  check_seal(path, seal);  // before HDF5 reads any of it
  if (H5Fis_hdf5(path.c_str()) <= 0) fail(path, "is missing or not an HDF5 file");
  const AccessList fapl(false);
  const hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get() < 0 ? H5P_DEFAULT : fapl.get());
  if (id < 0) fail(path, "cannot be opened (corrupt?)");
  return H5File(id, path);
}

H5File::H5File(H5File&& o) noexcept
    : id_(o.id_),
      path_(std::move(o.path_)),
      fd_(o.fd_),
      disk_path_(std::move(o.disk_path_)),
      uncaught_at_create_(o.uncaught_at_create_) {
  o.id_ = -1;
  o.fd_ = -1;
}

void H5File::release() noexcept {
  if (id_ >= 0) {
    // The strong close degree closes the file's objects with it; any object id still valid
    // after a failed close is closed one by one, then the file again.
    if (H5Fclose(id_) < 0 && H5Iis_valid(id_) > 0) {
      const ssize_t n = H5Fget_obj_count(id_, H5F_OBJ_ALL | H5F_OBJ_LOCAL);
      if (n > 0) {
        std::vector<hid_t> ids(static_cast<std::size_t>(n));
        const ssize_t got =
            H5Fget_obj_ids(id_, H5F_OBJ_ALL | H5F_OBJ_LOCAL, ids.size(), ids.data());
        for (ssize_t k = 0; k < got; ++k) {
          const hid_t obj = ids[static_cast<std::size_t>(k)];
          if (obj == id_) continue;
          switch (H5Iget_type(obj)) {
            case H5I_DATASET:
              H5Dclose(obj);
              break;
            case H5I_GROUP:
              H5Gclose(obj);
              break;
            case H5I_DATATYPE:
              H5Tclose(obj);
              break;
            case H5I_ATTR:
              H5Aclose(obj);
              break;
            default:
              break;
          }
        }
      }
      H5Fclose(id_);
    }
    id_ = -1;
  }
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
}

void H5File::write_image_and_close() {
  // Everything the metadata cache holds goes into the in-memory image first.
  const ssize_t size =
      H5Fflush(id_, H5F_SCOPE_GLOBAL) < 0 ? -1 : H5Fget_file_image(id_, nullptr, 0);
  std::vector<char> image(size > 0 ? static_cast<std::size_t>(size) : 0);
  if (size <= 0 || H5Fget_file_image(id_, image.data(), image.size()) != size) {
    release();
    remove_written_file(disk_path_);
    fail(path_, "cannot be flushed (HDF5 error)");
  }
  const std::vector<char> seal = seal_block(image);
  try {
    write_all(fd_, seal.data(), seal.size(), path_);
    write_all(fd_, image.data(), image.size(), path_);
    if (::fsync(fd_) != 0) throw_file_error(path_, "", errno);
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) throw_file_error(path_, "", errno);
  } catch (...) {
    release();
    remove_written_file(disk_path_);
    throw;
  }
  release();
}

H5File::~H5File() {
  if (fd_ >= 0) {
    if (std::uncaught_exceptions() > uncaught_at_create_) {
      release();
      remove_written_file(disk_path_);
      return;
    }
    try {
      write_image_and_close();  // removes the file on disk when it fails
    } catch (...) {
    }
  }
  release();
}

void H5File::close() {
  if (id_ < 0 && fd_ < 0) return;
  if (fd_ >= 0) {
    write_image_and_close();
    return;
  }
  const herr_t status = H5Fclose(id_);
  if (status < 0) release();
  id_ = -1;
  if (status < 0) fail(path_, "cannot be closed");
}

void H5File::ensure_parent_groups(const std::string& name) {
  for (size_t pos = name.find('/', 1); pos != std::string::npos; pos = name.find('/', pos + 1)) {
    const std::string group = name.substr(0, pos);
    if (H5Lexists(id_, group.c_str(), H5P_DEFAULT) > 0) continue;
    const Handle g(H5Gcreate2(id_, group.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    if (!g.ok()) fail(path_, "cannot create group " + group);
  }
}

void H5File::write_raw(const std::string& name, hid_t type, const void* data, hsize_t rows,
                       hsize_t cols) {
  ensure_parent_groups(name);
  const hsize_t dims[2] = {rows, cols};
  const Handle space(H5Screate_simple(2, dims, nullptr), H5Sclose);
  if (!space.ok()) fail(path_, "cannot create a dataspace for " + name);
  const Handle set(
      H5Dcreate2(id_, name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose);
  if (!set.ok() || H5Dwrite(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail(path_, "cannot write dataset " + name);
}

void H5File::write(const std::string& n, const double* d, hsize_t r, hsize_t c) {
  write_raw(n, H5T_NATIVE_DOUBLE, d, r, c);
}
void H5File::write(const std::string& n, const int* d, hsize_t r, hsize_t c) {
  write_raw(n, H5T_NATIVE_INT, d, r, c);
}
void H5File::write(const std::string& n, const unsigned long long* d, hsize_t r, hsize_t c) {
  write_raw(n, H5T_NATIVE_ULLONG, d, r, c);
}

namespace {
void write_scalar_attribute(hid_t file, const std::string& path, const std::string& name,
                            hid_t type, const void* value) {
  const Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  const Handle a(
      space.ok() ? H5Acreate2(file, name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT) : -1,
      H5Aclose);
  if (!a.ok() || H5Awrite(a.get(), type, value) < 0) fail(path, "cannot write attribute " + name);
}
}  // namespace

void H5File::write_attribute(const std::string& name, double value) {
  write_scalar_attribute(id_, path_, name, H5T_NATIVE_DOUBLE, &value);
}

void H5File::write_attribute(const std::string& name, long long value) {
  write_scalar_attribute(id_, path_, name, H5T_NATIVE_LLONG, &value);
}

void H5File::write_attribute(const std::string& name, const std::string& value) {
  const Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  if (!type.ok() || H5Tset_size(type.get(), value.size() + 1) < 0)
    fail(path_, "cannot write attribute " + name);
  write_scalar_attribute(id_, path_, name, type.get(), value.c_str());
}

bool H5File::has(const std::string& name) const {
  return H5Lexists(id_, name.c_str(), H5P_DEFAULT) > 0;
}

bool H5File::has_attribute(const std::string& name) const {
  return H5Aexists(id_, name.c_str()) > 0;
}

std::pair<hsize_t, hsize_t> H5File::read_raw(const std::string& name, hid_t type,
                                             std::function<void*(size_t)> alloc) const {
  if (!has(name)) fail(path_, "has no dataset " + name);
  const Handle set(H5Dopen2(id_, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.ok()) fail(path_, "cannot open dataset " + name);
  const Handle space(H5Dget_space(set.get()), H5Sclose);
  if (!space.ok()) fail(path_, "cannot read the shape of dataset " + name);
  hsize_t dims[2] = {0, 1};
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 1 || rank > 2) fail(path_, "dataset " + name + " is not 1-D or 2-D");
  if (H5Sget_simple_extent_dims(space.get(), dims, nullptr) < 0)
    fail(path_, "cannot read the shape of dataset " + name);
  void* buffer = alloc(dims[0] * dims[1]);
  if (H5Dread(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer) < 0)
    fail(path_, "cannot read dataset " + name);
  return {dims[0], dims[1]};
}

std::pair<hsize_t, hsize_t> H5File::read(const std::string& n, std::vector<double>& out) const {
  return read_raw(n, H5T_NATIVE_DOUBLE, [&](size_t k) {
    out.resize(k);
    return static_cast<void*>(out.data());
  });
}
std::pair<hsize_t, hsize_t> H5File::read(const std::string& n, std::vector<int>& out) const {
  return read_raw(n, H5T_NATIVE_INT, [&](size_t k) {
    out.resize(k);
    return static_cast<void*>(out.data());
  });
}
std::pair<hsize_t, hsize_t> H5File::read(const std::string& n,
                                         std::vector<unsigned long long>& out) const {
  return read_raw(n, H5T_NATIVE_ULLONG, [&](size_t k) {
    out.resize(k);
    return static_cast<void*>(out.data());
  });
}

double H5File::read_attribute_double(const std::string& name) const {
  double v = 0;
  const Handle a(H5Aopen(id_, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.ok() || H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v) < 0)
    fail(path_, "has no attribute " + name);
  return v;
}

long long H5File::read_attribute_int(const std::string& name) const {
  long long v = 0;
  const Handle a(H5Aopen(id_, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.ok() || H5Aread(a.get(), H5T_NATIVE_LLONG, &v) < 0)
    fail(path_, "has no attribute " + name);
  return v;
}

std::string H5File::read_attribute_string(const std::string& name) const {
  const Handle a(H5Aopen(id_, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.ok()) fail(path_, "has no attribute " + name);
  const Handle type(H5Aget_type(a.get()), H5Tclose);
  if (!type.ok() || H5Tget_class(type.get()) != H5T_STRING)
    fail(path_, "attribute " + name + " is not a string");
  const size_t size = H5Tget_size(type.get());
  if (size == 0 || size > (std::size_t(1) << 20))
    fail(path_, "attribute " + name + " has an implausible size");
  std::string s(size, '\0');
  const Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
  if (!mem.ok() || H5Tset_size(mem.get(), size) < 0 || H5Aread(a.get(), mem.get(), s.data()) < 0)
    fail(path_, "cannot read attribute " + name);
  s.resize(s.find('\0') == std::string::npos ? s.size() : s.find('\0'));
  return s;
}

namespace {

/// The datatype's description (HDF5's own encoding of it: class, size, byte order, and for
/// floating point the sign, exponent and mantissa layout and the bias), then the bytes of an
/// attribute or dataset as stored (that datatype, no conversion). Both count: the same bytes
/// read through another description are another value.
std::string stored_bytes(hid_t type, hssize_t elements, const std::function<herr_t(void*)>& read,
                         const std::string& path, const std::string& what) {
  const size_t size = H5Tget_size(type);
  if (size == 0 || elements < 0 || static_cast<double>(size) * static_cast<double>(elements) > 1e10)
    fail(path, what + " has an implausible size");
  size_t encoded = 0;
  if (H5Tencode(type, nullptr, &encoded) < 0 || encoded == 0 || encoded > (size_t(1) << 16))
    fail(path, "cannot read the datatype of " + what);
  std::string bytes(encoded + size * static_cast<size_t>(elements), '\0');
  if (H5Tencode(type, bytes.data(), &encoded) < 0)
    fail(path, "cannot read the datatype of " + what);
  if (bytes.size() > encoded && read(bytes.data() + encoded) < 0) fail(path, "cannot read " + what);
  return bytes;
}

struct ChecksumVisit {
  const std::string* path;
  std::vector<std::pair<std::string, std::string>> items;  // (name, shape + bytes)
  std::string error;
};

herr_t visit_dataset(hid_t group, const char* name, const H5L_info_t*, void* data) {
  auto& v = *static_cast<ChecksumVisit*>(data);
  const Handle object(H5Oopen(group, name, H5P_DEFAULT), H5Oclose);
  if (!object.ok()) {
    v.error = std::string("cannot open object ") + name;
    return -1;
  }
  if (H5Iget_type(object.get()) != H5I_DATASET) return 0;
  try {
    const Handle type(H5Dget_type(object.get()), H5Tclose);
    const Handle space(H5Dget_space(object.get()), H5Sclose);
    if (!type.ok() || !space.ok()) throw std::runtime_error("");
    const int rank = H5Sget_simple_extent_ndims(space.get());
    if (rank < 0 || rank > 8) throw std::runtime_error("");
    std::vector<hsize_t> dims(static_cast<size_t>(rank));
    if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0)
      throw std::runtime_error("");
    std::string record(reinterpret_cast<const char*>(dims.data()), dims.size() * sizeof(hsize_t));
    record += stored_bytes(
        type.get(), H5Sget_simple_extent_npoints(space.get()),
        [&](void* b) {
          return H5Dread(object.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, b);
        },
        *v.path, std::string("dataset ") + name);
    v.items.emplace_back(std::string("/") + name, std::move(record));
  } catch (const std::exception&) {
    v.error = std::string("cannot read dataset ") + name;
    return -1;
  }
  return 0;
}

struct AttributeVisit {
  const std::string* path;
  const std::string* skip;
  std::vector<std::pair<std::string, std::string>> items;
  std::string error;
};

herr_t visit_attribute(hid_t location, const char* name, const H5A_info_t*, void* data) {
  auto& v = *static_cast<AttributeVisit*>(data);
  if (*v.skip == name) return 0;
  try {
    const Handle a(H5Aopen(location, name, H5P_DEFAULT), H5Aclose);
    if (!a.ok()) throw std::runtime_error("");
    const Handle type(H5Aget_type(a.get()), H5Tclose);
    const Handle space(H5Aget_space(a.get()), H5Sclose);
    if (!type.ok() || !space.ok()) throw std::runtime_error("");
    v.items.emplace_back(name, stored_bytes(
                                   type.get(), H5Sget_simple_extent_npoints(space.get()),
                                   [&](void* b) { return H5Aread(a.get(), type.get(), b); },
                                   *v.path, std::string("attribute ") + name));
  } catch (const std::exception&) {
    v.error = std::string("cannot read attribute ") + name;
    return -1;
  }
  return 0;
}

}  // namespace

std::uint64_t H5File::content_checksum(const std::string& skip_attribute) const {
  ChecksumVisit sets{&path_, {}, {}};
  if (H5Lvisit(id_, H5_INDEX_NAME, H5_ITER_INC, visit_dataset, &sets) < 0)
    fail(path_, sets.error.empty() ? "cannot list its datasets" : sets.error);
  AttributeVisit attributes{&path_, &skip_attribute, {}, {}};
  hsize_t at = 0;
  if (H5Aiterate2(id_, H5_INDEX_NAME, H5_ITER_INC, &at, visit_attribute, &attributes) < 0)
    fail(path_, attributes.error.empty() ? "cannot list its attributes" : attributes.error);
  Fnv1a f;
  for (const auto* items : {&sets.items, &attributes.items}) {
    const std::uint64_t count = items->size();
    f.add(&count, sizeof count);
    for (const auto& [name, bytes] : *items) {
      f.add(name);
      f.add(bytes);
    }
  }
  return f.h;
}

}  // namespace rbc
