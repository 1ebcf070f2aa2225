// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/h5file.hpp"

#include <stdexcept>
#include <utility>

#include "core/fnv1a.hpp"

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

H5File H5File::create(const std::string& path, const std::string& name_in_errors) {
  silence();
  const std::string shown = name_in_errors.empty() ? path : name_in_errors;
  const hid_t id = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (id < 0) fail(shown, "cannot be created (is the directory writable?)");
  return H5File(id, shown);
}

H5File H5File::open_read(const std::string& path) {
  silence();
  if (H5Fis_hdf5(path.c_str()) <= 0) fail(path, "is missing or not an HDF5 file");
  const hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) fail(path, "cannot be opened (corrupt?)");
  return H5File(id, path);
}

H5File::H5File(H5File&& o) noexcept : id_(o.id_), path_(std::move(o.path_)) {
  o.id_ = -1;
}
H5File::~H5File() {
  if (id_ >= 0) H5Fclose(id_);
}
void H5File::close() {
  if (id_ < 0) return;
  const herr_t status = H5Fclose(id_);
  id_ = -1;
  if (status < 0) fail(path_, "cannot be flushed and closed");
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
