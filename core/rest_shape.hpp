// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The Evans-Fung biconcave rest shape and closed triangulations of it.
#include <string>
#include <vector>

#include "core/mesh.hpp"

namespace rbc {

/// Evans-Fung biconcave disc (MODEL.md section 1; Evans & Fung 1972):
/// z(r) = +-R sqrt(1 - r^2/R^2) (c0 + c1 r^2/R^2 + c2 r^4/R^4), disc in the x-y plane.
struct EvansFungShape {
  double radius_um = 3.91;
  double c0 = 0.1035805;
  double c1 = 1.001270;  ///< the paper's value; Evans-Fung's original is 1.001279
  double c2 = -0.561381;
};

/// Reference numbers of MODEL.md section 1 (closed forms evaluated there).
inline constexpr double kEvansFungArea_um2 = 134.09;
inline constexpr double kEvansFungVolume_um3 = 94.09;
inline constexpr double kEvansFungDiameter_um = 7.82;

/// Maps a point s on the unit sphere onto the Evans-Fung surface:
/// P(s) = R (s_x, s_y, s_z g(s_x^2 + s_y^2)), g(t) = c0 + c1 t + c2 t^2. Smooth everywhere
/// (the dimple centres are the images of the poles), so meshes can slide over it freely.
Eigen::Vector3d evans_fung_point(const EvansFungShape& shape, const Eigen::Vector3d& s);
/// Jacobian dP/ds (3 x 3) of evans_fung_point.
Eigen::Matrix3d evans_fung_jacobian(const EvansFungShape& shape, const Eigen::Vector3d& s);

/// How the triangulation is laid on the surface.
enum class RestMeshQuality {
  /// Geodesic icosphere mapped by P(s), then Phi = 1/2 sum L^2 - sqrt3 A minimised with
  /// vertices sliding on the surface: triangles as equilateral as the surface allows.
  phi_minimised,
  /// Geodesic icosphere mapped by P(s) only (rim triangles squashed ~2:1).
  projected,
  /// Icosphere remapped so that sphere latitude bands keep their area fraction on the
  /// cell (equal-area map): a deliberately poor network for the prestress study.
  equal_area,
};

/// Where the triangulation's icosahedron lies on the cell (make_icosphere's base corners).
enum class TriangulationOrientation {
  /// A corner at each dimple centre, a five-fold axis along z (the default meshes). The
  /// mesh keeps four of the scene's eight mirror elements: y -> -y, the inversion and the
  /// half turn about y (core/mirror_symmetry.hpp find_mirror_symmetry).
  dimple_vertex,
  /// Three mutually orthogonal two-fold axes of the icosahedron along x, y and z (the
  /// pyritohedral orientation): the icosahedron, and so the geodesic icosphere of any
  /// frequency, is invariant under the reflections in the three coordinate planes, the full
  /// mirror group of the stretch scene (order 8). A symmetric solve then works on one eighth
  /// of the cell, as the paper does. Another triangulation, so another discretisation: its
  /// diameters differ from dimple_vertex's at the discretisation error (README, "Mirror
  /// symmetry").
  mirror_planes,
};

struct RestShapeOptions {
  EvansFungShape shape;
  int target_vertices = 2000;  ///< N, 100 to 40,000; the mesh has N within 10 %
  RestMeshQuality quality = RestMeshQuality::phi_minimised;
  int max_phi_iterations = 6000;  ///< L-BFGS iterations for the Phi minimisation
  /// Stop when the largest tangential Phi gradient is below this fraction of the mean edge.
  double phi_tolerance = 1e-4;
  /// Scale the mesh about its centre so that it encloses exactly the Evans-Fung volume.
  /// An inscribed polyhedron loses volume at second order in the edge length (0.5 % at
  /// N = 2,000 for near-equilateral triangles, which are coarse across the rim); the scale
  /// factor is reported (1.0018 at N = 2,000, 1.0001 at N = 27,500).
  bool match_volume = true;
  /// Orientation of the triangulation on the cell: 0 (default) lays the icosphere as
  /// make_icosphere builds it; any other value first turns the unit icosphere by a
  /// uniformly distributed random rotation drawn from this seed (Shoemake's quaternion
  /// method on a std::mt19937_64 stream), so the 12 degree-5 vertices and the rows of
  /// triangles land elsewhere on the cell. Same seed, same mesh. Used to measure how much
  /// a result depends on where the triangulation happens to lie (the reference spread).
  unsigned rotation_seed = 0;
  /// Where the icosahedron lies before rotation_seed's turn (which, if not 0, breaks the
  /// mirror_planes symmetry).
  TriangulationOrientation orientation = TriangulationOrientation::dimple_vertex;
};

/// The rotation rotation_seed selects (identity for 0): proper orthogonal, det = +1.
Eigen::Matrix3d triangulation_rotation(unsigned rotation_seed);
/// The rotation that lays make_icosphere's icosahedron in `orientation` (identity for
/// dimple_vertex): proper orthogonal, det = +1.
Eigen::Matrix3d orientation_rotation(TriangulationOrientation orientation);

/// Exact area (um^2) and volume (um^3) of the Evans-Fung surface by adaptive quadrature
/// (GSL QAGS) of the surface of revolution: A = 2 int 2 pi r sqrt(1 + z'(r)^2) dr,
/// V = 2 int 2 pi r z(r) dr. MODEL.md quotes 134.09 um^2 and 94.09 um^3.
struct EvansFungMeasures {
  double area_um2 = 0, volume_um3 = 0, diameter_um = 0;
};
EvansFungMeasures evans_fung_measures(const EvansFungShape& shape);

/// Mesh quality report printed with every run (MODEL.md section 2, "Residual forces").
struct MeshQualityReport {
  int vertices = 0, edges = 0, faces = 0;
  double area_um2 = 0, volume_um3 = 0, diameter_um = 0, thickness_um = 0;
  double phi_over_area = 0;  ///< Phi/A, dimensionless; 0 only for all-equilateral triangles
  double edge_min_um = 0, edge_mean_um = 0, edge_max_um = 0;
  double worst_aspect_ratio = 0;  ///< see triangle_aspect_ratio
  std::vector<int> degree_histogram;
  int phi_iterations = 0;
  double volume_scale = 1.0;  ///< factor applied by match_volume
};

/// Phi = 1/2 sum_e L_e^2 - sqrt3 sum_f A_f (um^2) >= 0 (Weitzenboeck), and optionally its
/// gradient (3 x N, um). The in-plane network force at rest is (f_WLC(Lbar)/Lbar) grad Phi.
double equilateral_defect(const Positions& x, const Topology& topo, Positions* grad = nullptr);

/// Geodesic (class I) icosphere of the given frequency on the unit sphere:
/// 10 f^2 + 2 vertices, 20 f^2 faces, outward oriented.
TriMesh make_icosphere(int frequency);

/// Frequency whose icosphere has the vertex count closest to n (n >= 12).
int icosphere_frequency_for(int vertices);

/// Closed triangulation of the Evans-Fung surface with about options.target_vertices
/// vertices. Throws std::invalid_argument if target_vertices is outside [100, 40000].
TriMesh make_rest_shape(const RestShapeOptions& options, MeshQualityReport* report = nullptr);

MeshQualityReport assess_mesh(const TriMesh& mesh);

std::string to_string(RestMeshQuality quality);
RestMeshQuality rest_mesh_quality_from_string(const std::string& name);
/// "dimple-vertex" | "mirror-planes"; the parser throws std::invalid_argument naming the
/// accepted names.
std::string to_string(TriangulationOrientation orientation);
TriangulationOrientation triangulation_orientation_from_string(const std::string& name);

}  // namespace rbc
