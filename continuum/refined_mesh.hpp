// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Continuum meshes graded to the stretch scene that keep the uniform mesh's mirror symmetry:
// the Phi-minimised icosphere of core/rest_shape.hpp refined locally by red-green refinement.
//
// Each level marks the triangles whose size (the edge of the equilateral triangle of the same
// area) exceeds the size field h at their centroid, red-refines them (four children through the
// edge midpoints), and closes the mesh: a triangle with two or three split edges, or with a split
// edge whose half is split again, is red-refined as well (repeated until none is left), and a
// triangle with one split edge is bisected from that edge's midpoint to the opposite corner
// (green). The green closures are temporary: the next level marks and refines the red triangles
// only (a green pair is never split again), so every triangle is a red descendant of a coarse one
// or one half of it, and the angles stay within those of the coarse mesh and their halves. New
// vertices go onto the Evans-Fung surface (Newton's method along the gradient of
// evans_fung_level, continuum/adapted_mesh.hpp); the mesh is then scaled to enclose the
// Evans-Fung volume, as the uniform meshes are.
//
// Why the refinement keeps the mirror group G of the coarse mesh (core/mirror_symmetry.hpp): the
// size field is invariant under the three coordinate mirrors, and the marked set is closed under
// G explicitly (a triangle is marked when any image of it is, so a size within round-off of the
// threshold cannot break the tie differently for two images). Every further step is a function of
// the marked set and the mesh's combinatorics alone: the closure rules (two split edges, a
// doubly split edge) are invariant under relabelling, and the green closure of a triangle with
// one split edge has exactly one choice (the split edge's midpoint to the opposite corner), unlike
// longest-edge bisection or a Delaunay flip, which would pick among congruent mirror images by
// vertex order or round-off. So an element g of G maps the refined triangulation onto itself: a
// midpoint of edge (a, b) onto the midpoint of (g a, g b), which exists, and the projection onto
// the surface commutes with g because the level function is invariant under the mirrors.
#include <functional>

#include "continuum/adapted_mesh.hpp"
#include "core/geometry.hpp"
#include "core/mesh.hpp"
#include "core/mirror_symmetry.hpp"
#include "core/rest_shape.hpp"

namespace rbc {

/// The size field of the refined mesh (target edge length, um), invariant under the three
/// coordinate mirrors: fine_um on the bead caps beyond |X_x| >= plane_um - band_um and within
/// rim_band_um of the two points (0, +-rim_y_um, 0) of the rest rim where D_T is measured (the
/// widest points across the middle of the cell), growing by `grading` um per um of distance from
/// those regions; infinite nowhere (it grows without bound, the coarse mesh caps the size).
struct RefinedSizeField {
  double fine_um = 0.3;
  double plane_um = 3.6;     ///< contact-cap plane |X_x| = c (rest_contact_plane)
  double band_um = 0.3;      ///< the cap's fine region reaches this far inside the cap plane
  double rim_y_um = 3.91;    ///< |y| of the rest rim's widest points (the Evans-Fung radius)
  double rim_band_um = 0.6;  ///< radius of the fine region around each rim point
  double grading = 0.5;      ///< dh / d(distance) beyond the fine regions (dimensionless)
  double operator()(const Vec3& x_um) const;
};

/// Red-green refinement of a closed triangulation of the Evans-Fung surface (vertices on the
/// surface, faces outward) by a size field, as described at the top of this file: at most
/// max_levels levels (>= 0), stopping early when no triangle is marked. `symmetry_tolerance_um`
/// is find_mirror_symmetry's tolerance for the coarse mesh's group, whose marked sets are closed
/// under it. The result is not volume-matched. std::invalid_argument for max_levels < 0;
/// std::logic_error if the refinement breaks the coarse mesh's symmetry (it cannot, see above).
TriMesh refine_evans_fung_mesh(const TriMesh& coarse, const EvansFungShape& shape,
                               const SizeField& size_um, int max_levels,
                               double symmetry_tolerance_um = kMirrorToleranceUm);

/// Options of make_refined_mesh.
struct RefinedMeshOptions {
  EvansFungShape shape;
  /// Target number of triangles, kMinContinuumElements to kMaxContinuumElements. The coarse
  /// icosphere's frequency is chosen so that the refined mesh's count comes closest among the
  /// frequencies tried (at most 6; the one the count's scaling points to and its neighbours on
  /// the target's side). Counts move in steps of about 2 / f of the count per step f -> f + 1,
  /// and the coarsest icosphere (f = 4, 320 triangles) sets the smallest count.
  int target_elements = 2000;
  /// Coarse mesh's equivalent edge / fine size, in [1, 10] (2: one level of red refinement at
  /// the rims, 4: two).
  double size_ratio = 2.0;
  /// Contact fraction of the bead caps whose rims are refined (TweezersParameters'), in (0, 0.5).
  double contact_fraction = 0.05;
  /// Width of the fine band inside the cap plane, in fine sizes, in [0, 20].
  double band_fine_sizes = 1.0;
  /// Radius of the fine region around the D_T rim points, in fine sizes, in [0, 20]. D_T's error
  /// is set by the whole rim arc around x = 0, not by the two points alone: on the 320-element
  /// icosphere at size ratio 3 (full law, exact contact, quadric fit, 13 forces against the
  /// network reference) radii of 2, 4 and 6 fine sizes give 1,952, 2,368 and 2,984 triangles
  /// erring by 0.39, 0.31 and 0.26 % (D_T at 30 to 190 pN).
  double rim_fine_sizes = 6.0;
  /// dh / d(distance) beyond the fine regions, in (0, 2].
  double grading = 0.5;
  /// Where the coarse icosahedron lies (dimple_vertex keeps 4 mirror elements, mirror_planes 8).
  TriangulationOrientation orientation = TriangulationOrientation::dimple_vertex;
  /// Turns the coarse icosphere by a random rotation (RestShapeOptions::rotation_seed; 0: not
  /// turned): another triangulation under the same size field, the analogue of the uniform
  /// mesh's rotations. The coarse frequency is the unturned mesh's for the same target (so the
  /// turns of one request are turns of one coarse mesh; their refined counts differ by a few %
  /// as the rims cut other triangles). A turned mesh keeps none of the scene's mirrors.
  unsigned seed = 0;
  int max_levels = 6;  ///< refinement levels, in [0, 10]
  /// Scale the mesh about its centre so that it encloses the Evans-Fung volume exactly, as
  /// RestShapeOptions::match_volume does for the uniform meshes (true), or keep every vertex on
  /// the Evans-Fung surface (false, the default). The polyhedron of vertices on the surface
  /// encloses less than the surface (its chords cut inside the convex rim, by O(h^2) of the
  /// local edge h), and the scale factor that gives the volume back is set by the coarsest
  /// triangles, so it moves the fine rims off the surface by the coarse regions' deficit. With
  /// the quadric-fit diameters (the smooth surface through the vertices) that offset is an error
  /// refinement cannot remove: over the 13 Mills forces, worst over 4 orientations, against the
  /// spectrin-level network, the scaled mesh of 2,748 triangles (size ratio 2) errs by 0.35 %
  /// (0.18 % already at 0 pN), the same mesh on the surface by 0.25 % (0.06 % at 0 pN); at 4,368
  /// triangles 0.24 % against 0.15 %. On the surface the rest volume is the polyhedron's, which
  /// the volume constraint then keeps, as it keeps any rest mesh's.
  bool match_volume = false;
  /// Throws rbc::InvalidParameter naming the first value out of range.
  void validate() const;
};

/// What make_refined_mesh built.
struct RefinedMeshReport {
  RefinedSizeField size;    ///< the field of the chosen mesh
  int coarse_vertices = 0;  ///< the coarse icosphere's
  int coarse_elements = 0;
  int passes = 0;  ///< coarse meshes refined to meet the element count
  int vertices = 0, elements = 0;
  double volume_scale = 1.0;  ///< factor applied by match_volume (1 without it)
};

/// A mesh of about target_elements triangles: the Phi-minimised icosphere (frequency chosen for
/// the count, options.orientation) refined by RefinedSizeField with fine_um = the coarse mesh's
/// mean equivalent edge / size_ratio, then volume-matched. Same options, same mesh.
TriMesh make_refined_mesh(const RefinedMeshOptions& options, RefinedMeshReport* report = nullptr);

}  // namespace rbc
