// SPDX-License-Identifier: GPL-3.0-or-later
// Meshes: the Evans-Fung rest triangulation, continuum meshes and user meshes, with their
// quality report; positions (N, 3) float64 um and faces (F, 3) int32 as views without copies.
#include "common.hpp"
#include "continuum/continuum_model.hpp"
#include "core/geometry.hpp"

namespace rbc::py_bind {

namespace {

py::dict quality_dict(const MeshQualityReport& r) {  // the keys of `rbc mesh --json`
  py::dict d;
  d["vertices"] = r.vertices;
  d["edges"] = r.edges;
  d["faces"] = r.faces;
  d["area_um2"] = r.area_um2;
  d["volume_um3"] = r.volume_um3;
  d["diameter_um"] = r.diameter_um;
  d["thickness_um"] = r.thickness_um;
  d["phi_over_area"] = r.phi_over_area;
  d["edge_min_um"] = r.edge_min_um;
  d["edge_mean_um"] = r.edge_mean_um;
  d["edge_max_um"] = r.edge_max_um;
  d["worst_aspect_ratio"] = r.worst_aspect_ratio;
  d["degree_histogram"] = r.degree_histogram;
  d["phi_iterations"] = r.phi_iterations;
  d["volume_scale"] = r.volume_scale;
  return d;
}

MeshQualityReport quality_from_dict(const py::dict& d) {
  MeshQualityReport r;
  r.vertices = d["vertices"].cast<int>();
  r.edges = d["edges"].cast<int>();
  r.faces = d["faces"].cast<int>();
  r.area_um2 = d["area_um2"].cast<double>();
  r.volume_um3 = d["volume_um3"].cast<double>();
  r.diameter_um = d["diameter_um"].cast<double>();
  r.thickness_um = d["thickness_um"].cast<double>();
  r.phi_over_area = d["phi_over_area"].cast<double>();
  r.edge_min_um = d["edge_min_um"].cast<double>();
  r.edge_mean_um = d["edge_mean_um"].cast<double>();
  r.edge_max_um = d["edge_max_um"].cast<double>();
  r.worst_aspect_ratio = d["worst_aspect_ratio"].cast<double>();
  r.degree_histogram = d["degree_histogram"].cast<std::vector<int>>();
  r.phi_iterations = d["phi_iterations"].cast<int>();
  r.volume_scale = d["volume_scale"].cast<double>();
  return r;
}

/// A mesh from arrays: checks indices and builds the topology (ValueError unless closed).
std::shared_ptr<PyMesh> mesh_from_arrays(const py::handle& positions, const py::handle& faces) {
  Positions x = positions_from_array(positions, -1, "positions");
  const auto f = py::array_t<int, py::array::c_style | py::array::forcecast>::ensure(faces);
  if (!f || f.ndim() != 2 || f.shape(1) != 3)
    throw py::value_error("faces must be an integer array of shape (F, 3)");
  Faces faces_lib(3, f.shape(0));
  std::copy(f.data(), f.data() + f.size(), faces_lib.data());
  for (py::ssize_t k = 0; k < f.size(); ++k)
    if (faces_lib.data()[k] < 0 || faces_lib.data()[k] >= x.cols())
      throw py::value_error("faces index " + std::to_string(faces_lib.data()[k]) +
                            " is out of range: expected 0 to " + std::to_string(x.cols() - 1));
  auto mesh = std::make_shared<PyMesh>();
  const int n = static_cast<int>(x.cols());
  mesh->mesh.topo = build_topology(faces_lib, n);
  mesh->mesh.x = std::move(x);
  mesh->quality = assess_mesh(mesh->mesh);
  return mesh;
}

}  // namespace

void bind_mesh(py::module_& m) {
  py::class_<MeshQualityReport>(
      m, "MeshQualityReport",
      "Quality report of a closed triangulation (MODEL.md section 2, "
      "'Residual forces'): Phi/A is 0 only for all-equilateral triangles.")
      .def_readonly("vertices", &MeshQualityReport::vertices)
      .def_readonly("edges", &MeshQualityReport::edges)
      .def_readonly("faces", &MeshQualityReport::faces)
      .def_readonly("area_um2", &MeshQualityReport::area_um2)
      .def_readonly("volume_um3", &MeshQualityReport::volume_um3)
      .def_readonly("diameter_um", &MeshQualityReport::diameter_um)
      .def_readonly("thickness_um", &MeshQualityReport::thickness_um)
      .def_readonly("phi_over_area", &MeshQualityReport::phi_over_area)
      .def_readonly("edge_min_um", &MeshQualityReport::edge_min_um)
      .def_readonly("edge_mean_um", &MeshQualityReport::edge_mean_um)
      .def_readonly("edge_max_um", &MeshQualityReport::edge_max_um)
      .def_readonly("worst_aspect_ratio", &MeshQualityReport::worst_aspect_ratio)
      .def_readonly("degree_histogram", &MeshQualityReport::degree_histogram)
      .def_readonly("phi_iterations", &MeshQualityReport::phi_iterations)
      .def_readonly("volume_scale", &MeshQualityReport::volume_scale)
      .def("to_dict", &quality_dict, "The fields as `rbc mesh --json` prints them.")
      .def(py::pickle([](const MeshQualityReport& r) { return quality_dict(r); },
                      [](const py::dict& d) { return quality_from_dict(d); }))
      .def("__repr__", [](const MeshQualityReport& r) {
        return "MeshQualityReport(vertices=" + std::to_string(r.vertices) +
               ", area_um2=" + num(r.area_um2) + ", volume_um3=" + num(r.volume_um3) +
               ", phi_over_area=" + num(r.phi_over_area) + ")";
      });

  py::class_<PyMesh, std::shared_ptr<PyMesh>>(
      m, "Mesh",
      "A closed, consistently oriented triangle mesh. positions: (N, 3) float64 um, faces: (F, 3) "
      "int32 (counter-clockwise seen from outside); both are read-only views of the library's "
      "storage (no copy).")
      .def(py::init(&mesh_from_arrays), py::arg("positions"), py::arg("faces"),
           "A mesh from arrays; raises ValueError unless it is a closed oriented manifold.")
      .def_property_readonly(
          "positions", [](py::object self) { return rows_view(self.cast<PyMesh&>().mesh.x, self); },
          "(N, 3) float64 vertex positions in um (read-only view)")
      .def_property_readonly(
          "faces",
          [](py::object self) { return rows_view(self.cast<PyMesh&>().mesh.topo.faces, self); },
          "(F, 3) int32 vertex indices (read-only view)")
      .def_property_readonly(
          "edges",
          [](py::object self) { return rows_view(self.cast<PyMesh&>().mesh.topo.edges, self); },
          "(E, 2) int32 edge end points, first < second (read-only view)")
      .def_property_readonly("num_vertices",
                             [](const PyMesh& s) { return s.mesh.topo.num_vertices; })
      .def_property_readonly("num_faces", [](const PyMesh& s) { return s.mesh.topo.num_faces(); })
      .def_property_readonly("num_edges", [](const PyMesh& s) { return s.mesh.topo.num_edges(); })
      .def_readonly("quality", &PyMesh::quality, "MeshQualityReport of this mesh")
      .def(
          "vertex_areas_um2",
          [](const PyMesh& s) { return owning_vector(vertex_areas(s.mesh.x, s.mesh.topo)); },
          "(N,) barycentric vertex areas in um^2")
      .def(py::pickle(
          [](py::object self) {
            const PyMesh& s = self.cast<PyMesh&>();
            return py::make_tuple(py::array(rows_view(s.mesh.x, self)).attr("copy")(),
                                  py::array(rows_view(s.mesh.topo.faces, self)).attr("copy")(),
                                  s.quality);
          },
          [](const py::tuple& t) {
            auto mesh = mesh_from_arrays(t[0], t[1]);
            mesh->quality = t[2].cast<MeshQualityReport>();  // e.g. the rest shape's own report
            return mesh;
          }))
      .def("__repr__", [](const PyMesh& s) {
        return "Mesh(vertices=" + std::to_string(s.mesh.topo.num_vertices) +
               ", faces=" + std::to_string(s.mesh.topo.num_faces()) + ")";
      });

  m.def(
      "rest_shape",
      [](int vertices, const py::object& quality, int max_phi_iterations, bool match_volume,
         const std::string& orientation) {
        RestShapeOptions o;
        o.target_vertices = vertices;
        o.quality = enum_arg<RestMeshQuality>(quality, rest_mesh_quality_from_string);
        o.orientation = triangulation_orientation_from_string(orientation);
        o.max_phi_iterations = max_phi_iterations;
        o.match_volume = match_volume;
        auto mesh = std::make_shared<PyMesh>();
        run_released(nullptr, [&] { mesh->mesh = make_rest_shape(o, &mesh->quality); });
        return mesh;
      },
      py::arg("vertices") = 2000, py::arg("quality") = "phi-minimised", py::kw_only(),
      py::arg("max_phi_iterations") = RestShapeOptions{}.max_phi_iterations,
      py::arg("match_volume") = true, py::arg("orientation") = "dimple-vertex",
      "Closed triangulation of the Evans-Fung rest shape with about `vertices` vertices (100 to "
      "40,000; within 10 %), as `rbc mesh`. quality: 'phi-minimised' (default), 'projected', "
      "'equal-area' or rbc.MeshQuality. orientation: 'dimple-vertex' (default) or "
      "'mirror-planes' (all three coordinate mirrors, `rbc mesh --orientation`). The returned "
      "Mesh carries its quality report.");

  m.def(
      "continuum_mesh",
      [](int elements, const std::string& orientation) {
        const TriangulationOrientation o = triangulation_orientation_from_string(orientation);
        auto mesh = std::make_shared<PyMesh>();
        run_released(nullptr,
                     [&] { mesh->mesh = make_continuum_mesh(elements, 0, o, &mesh->quality); });
        return mesh;
      },
      py::arg("elements") = 4000, py::kw_only(), py::arg("orientation") = "dimple-vertex",
      "Phi-minimised triangulation with about `elements` triangles (200 to 79,996), the mesh of "
      "`rbc stretch --model continuum` (orientation as rest_shape's).");

  m.def(
      "diameters",
      [](const py::handle& positions) {
        const Diameters d = measure_diameters(positions_from_array(positions, -1, "positions"));
        return py::make_tuple(d.axial_um, d.transverse_um);
      },
      py::arg("positions"),
      "(D_A, D_T) in um: D_A = max x - min x; D_T the widest extent perpendicular to x.");
}

}  // namespace rbc::py_bind
