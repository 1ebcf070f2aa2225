#include "core/io.hpp"

#include <unistd.h>
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

void write_text_atomic(const std::string& path, const std::string& text) {
  const std::string tmp = temporary_path_for(path);
  {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw std::runtime_error("cannot write '" + path + "'");
    }
  }
  commit_file(tmp, path);
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
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open CSV file '" + path + "'");
  return parse_csv(in, path);
}

void write_mesh_snapshot(const std::string& base, const MeshSnapshot& snap) {
  const std::string h5_path = base + ".h5", xdmf_path = base + ".xdmf";
  const std::string h5_name = fs::path(h5_path).filename().string();
  const auto nv = static_cast<hsize_t>(snap.x.cols()), nf = static_cast<hsize_t>(snap.faces.cols());
  const std::string tmp = temporary_path_for(h5_path);
  {
    H5File f = H5File::create(tmp);
    // A 3 x N column-major matrix is an N x 3 row-major table: the layout XDMF expects.
    f.write("/mesh/positions_um", snap.x.data(), nv, 3);
    f.write("/mesh/faces", snap.faces.data(), nf, 3);
    for (const auto& [name, v] : snap.vertex_fields)
      f.write("/vertex/" + name, v.data(), static_cast<hsize_t>(v.size()), 1);
    for (const auto& [name, v] : snap.face_fields)
      f.write("/face/" + name, v.data(), static_cast<hsize_t>(v.size()), 1);
    for (const auto& [name, value] : snap.attributes) f.write_attribute(name, value);
  }
  commit_file(tmp, h5_path);
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
