// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Continuum meshes graded to the stretch scene: closed triangulations of the Evans-Fung rest
// surface whose element size follows a size field h(X) (um), fine at the bead-contact rims and
// the pulled tips, coarse elsewhere.
//
// The surface is meshed by CGAL's surface mesher (CGAL::make_surface_mesh, Boissonnat and Oudot's
// Delaunay refinement; Debian 12's CGAL 5.5) on the implicit Evans-Fung function
// evans_fung_level, with two facet criteria: the radius of each facet's surface Delaunay ball is
// at most h(c) / sqrt(3) at the ball's centre c on the surface (an equilateral triangle of edge
// h has that circumradius), and the smallest angle is at least min_angle_deg. The mesher starts
// from deterministic points (the Evans-Fung images of an icosphere's vertices, turned by `seed`),
// not from random ones, so the same options give the same mesh. Its vertices are then put on the
// surface to round-off (Newton's method along the level function's gradient), the faces are
// oriented outward (counter-clockwise seen from outside, core/mesh.hpp) and the mesh is checked
// to be a closed oriented 2-manifold of genus 0.
//
// Delaunay refinement does not keep mirror symmetries: the adapted meshes have none of the
// scene's mirrors, so a continuum stretch on them runs in full (the --symmetry mirror reduction
// finds the trivial group).
#include <functional>

#include "core/geometry.hpp"
#include "core/mesh.hpp"
#include "core/rest_shape.hpp"

namespace rbc {

/// The Evans-Fung surface as the zero set of a level function (dimensionless):
///   f(X) = (z/R)^2 - (1 - t) g(min(t, 1))^2,  t = (x^2 + y^2)/R^2, g(t) = c0 + c1 t + c2 t^2,
/// negative inside, positive outside, zero exactly on the surface (evans_fung_point's image).
/// For t > 1 the factor g(1) keeps f > 0 away from the rim (g itself vanishes at t ~ 1.88).
double evans_fung_level(const EvansFungShape& shape, const Vec3& x_um);
/// Gradient of evans_fung_level (1/um).
Vec3 evans_fung_level_gradient(const EvansFungShape& shape, const Vec3& x_um);
/// x (um) put on the Evans-Fung surface by Newton steps along the level function's gradient
/// (at most 20; they stop below 1e-15 R): the point of the surface near x, for x near it.
Vec3 evans_fung_project(const EvansFungShape& shape, Vec3 x_um);

/// A size field on the rest surface: the target edge length (um) at a point.
using SizeField = std::function<double(const Vec3&)>;

/// The scene's size field: h = fine_um on the caps beyond |X_x| >= plane_um - band_um (the
/// contact rims and the pulled tips), growing by `grading` um per um of distance in |X_x| from
/// there, up to coarse_um.
struct SceneSizeField {
  double fine_um = 0.3, coarse_um = 0.9;
  double plane_um = 3.6;  ///< contact-cap plane |X_x| = c (rest_contact_plane)
  double band_um = 0.3;   ///< the fine region reaches this far inside the cap plane
  double grading = 0.5;   ///< dh / d|X_x| beyond the fine region (dimensionless)
  double operator()(const Vec3& x_um) const;
};

/// The plane c > 0 (um) of the cap {X_x >= c} of the Evans-Fung surface whose area is
/// `contact_fraction` of the total (the exact contact load's cap, continuum/contact_load.hpp,
/// on the smooth surface): computed on a fine projected icosphere (frequency 60, 36,002
/// vertices; its plane differs from the smooth surface's by < 1e-3 um). rbc::InvalidParameter
/// unless contact_fraction is finite and in (0, 0.5).
double rest_contact_plane(const EvansFungShape& shape, double contact_fraction);

/// Meshes the Evans-Fung surface with edge lengths bounded by size(X) (um; the mean edge is 0.7
/// to 0.8 of it, measured; size must be > 0 and finite on the surface, else
/// std::invalid_argument). `seed` turns the initial points
/// (core/rest_shape.hpp triangulation_rotation; 0: unturned): same seed, same mesh.
/// min_angle_deg in [10, 30] (the mesher's guaranteed range). Vertices lie on the surface to
/// round-off; faces oriented outward; std::runtime_error if the result is not a closed
/// genus-0 manifold (not seen in the measured range: uniform sizes 0.1 to 0.8 um, and the
/// graded fields of make_adapted_mesh from 490 to 32,560 triangles, coarse sizes up to 2.3 um).
TriMesh mesh_evans_fung_surface(const EvansFungShape& shape, const SizeField& size_um,
                                unsigned seed = 0, double min_angle_deg = 30.0);

/// Options of make_adapted_mesh.
struct AdaptedMeshOptions {
  EvansFungShape shape;
  /// Target number of triangles, kMinContinuumElements to kMaxContinuumElements; the fine size
  /// is rescaled (at most max_passes meshings) until the count is within element_tolerance.
  int target_elements = 2000;
  /// coarse / fine edge length, in [1, 10] (1: a uniform-size Delaunay mesh).
  double size_ratio = 2.0;
  /// Contact fraction of the bead caps whose rims are refined (TweezersParameters'), in (0, 0.5).
  double contact_fraction = 0.05;
  /// Width of the fine band inside the cap plane, in units of the fine size, in [0, 20].
  double band_fine_sizes = 1.0;
  /// dh / d|X_x| beyond the fine region, in (0, 2].
  double grading = 0.5;
  double min_angle_deg = 30.0;  ///< in [10, 30]
  unsigned seed = 0;            ///< turns the mesher's initial points
  double element_tolerance = 0.05;
  int max_passes = 6;
  /// Scale the mesh about its centre so that it encloses the Evans-Fung volume exactly, as
  /// RestShapeOptions::match_volume does for the uniform meshes.
  bool match_volume = true;
  /// Throws rbc::InvalidParameter naming the first value out of range.
  void validate() const;
};

/// What make_adapted_mesh built.
struct AdaptedMeshReport {
  SceneSizeField size;  ///< the field of the final pass
  int passes = 0;       ///< meshings run to meet the element count
  int vertices = 0, elements = 0;
  double volume_scale = 1.0;  ///< factor applied by match_volume
};

/// A mesh of about target_elements triangles graded by SceneSizeField: fine (h_f) on the caps
/// beyond |X_x| >= c - band_fine_sizes h_f, coarse (size_ratio h_f) elsewhere.
TriMesh make_adapted_mesh(const AdaptedMeshOptions& options, AdaptedMeshReport* report = nullptr);

/// Mean edge length (um) of the edges whose midpoints satisfy `select` (0 if none).
double mean_edge_length(const TriMesh& mesh, const std::function<bool(const Vec3&)>& select);

}  // namespace rbc
