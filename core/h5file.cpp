#include "core/h5file.hpp"

#include <stdexcept>

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

}  // namespace

H5File H5File::create(const std::string& path) {
  silence();
  const hid_t id = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (id < 0) fail(path, "cannot be created (is the directory writable?)");
  return H5File(id, path);
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
  close();
}
void H5File::close() {
  if (id_ >= 0) H5Fclose(id_);
  id_ = -1;
}

void H5File::ensure_parent_groups(const std::string& name) {
  for (size_t pos = name.find('/', 1); pos != std::string::npos; pos = name.find('/', pos + 1)) {
    const std::string group = name.substr(0, pos);
    if (H5Lexists(id_, group.c_str(), H5P_DEFAULT) > 0) continue;
    const hid_t g = H5Gcreate2(id_, group.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (g < 0) fail(path_, "cannot create group " + group);
    H5Gclose(g);
  }
}

void H5File::write_raw(const std::string& name, hid_t type, const void* data, hsize_t rows,
                       hsize_t cols) {
  ensure_parent_groups(name);
  const hsize_t dims[2] = {rows, cols};
  const hid_t space = H5Screate_simple(2, dims, nullptr);
  const hid_t set =
      H5Dcreate2(id_, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const herr_t status = set >= 0 ? H5Dwrite(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) : -1;
  if (set >= 0) H5Dclose(set);
  H5Sclose(space);
  if (status < 0) fail(path_, "cannot write dataset " + name);
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

void H5File::write_attribute(const std::string& name, double value) {
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate2(id_, name.c_str(), H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
  if (a < 0 || H5Awrite(a, H5T_NATIVE_DOUBLE, &value) < 0)
    fail(path_, "cannot write attribute " + name);
  H5Aclose(a);
  H5Sclose(space);
}

void H5File::write_attribute(const std::string& name, long long value) {
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate2(id_, name.c_str(), H5T_NATIVE_LLONG, space, H5P_DEFAULT, H5P_DEFAULT);
  if (a < 0 || H5Awrite(a, H5T_NATIVE_LLONG, &value) < 0)
    fail(path_, "cannot write attribute " + name);
  H5Aclose(a);
  H5Sclose(space);
}

void H5File::write_attribute(const std::string& name, const std::string& value) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.size() + 1);
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate2(id_, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
  if (a < 0 || H5Awrite(a, type, value.c_str()) < 0) fail(path_, "cannot write attribute " + name);
  H5Aclose(a);
  H5Sclose(space);
  H5Tclose(type);
}

bool H5File::has(const std::string& name) const {
  return H5Lexists(id_, name.c_str(), H5P_DEFAULT) > 0;
}

std::pair<hsize_t, hsize_t> H5File::read_raw(const std::string& name, hid_t type,
                                             std::function<void*(size_t)> alloc) const {
  if (!has(name)) fail(path_, "has no dataset " + name);
  const hid_t set = H5Dopen2(id_, name.c_str(), H5P_DEFAULT);
  if (set < 0) fail(path_, "cannot open dataset " + name);
  const hid_t space = H5Dget_space(set);
  hsize_t dims[2] = {0, 1};
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 1 || rank > 2) {
    H5Sclose(space);
    H5Dclose(set);
    fail(path_, "dataset " + name + " is not 1-D or 2-D");
  }
  H5Sget_simple_extent_dims(space, dims, nullptr);
  void* buffer = alloc(dims[0] * dims[1]);
  const herr_t status = H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
  H5Sclose(space);
  H5Dclose(set);
  if (status < 0) fail(path_, "cannot read dataset " + name);
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
  const hid_t a = H5Aopen(id_, name.c_str(), H5P_DEFAULT);
  if (a < 0 || H5Aread(a, H5T_NATIVE_DOUBLE, &v) < 0) fail(path_, "has no attribute " + name);
  H5Aclose(a);
  return v;
}

long long H5File::read_attribute_int(const std::string& name) const {
  long long v = 0;
  const hid_t a = H5Aopen(id_, name.c_str(), H5P_DEFAULT);
  if (a < 0 || H5Aread(a, H5T_NATIVE_LLONG, &v) < 0) fail(path_, "has no attribute " + name);
  H5Aclose(a);
  return v;
}

std::string H5File::read_attribute_string(const std::string& name) const {
  const hid_t a = H5Aopen(id_, name.c_str(), H5P_DEFAULT);
  if (a < 0) fail(path_, "has no attribute " + name);
  const hid_t type = H5Aget_type(a);
  const size_t size = H5Tget_size(type);
  std::string s(size, '\0');
  const hid_t mem = H5Tcopy(H5T_C_S1);
  H5Tset_size(mem, size);
  const herr_t status = H5Aread(a, mem, s.data());
  H5Tclose(mem);
  H5Tclose(type);
  H5Aclose(a);
  if (status < 0) fail(path_, "cannot read attribute " + name);
  s.resize(s.find('\0') == std::string::npos ? s.size() : s.find('\0'));
  return s;
}

}  // namespace rbc
