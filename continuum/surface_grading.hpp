// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Graded meshes that keep their connectivity (r-adaptation): the vertices of a triangulation of
// the Evans-Fung surface are moved along the surface so that edge lengths follow a size field,
// and no vertex changes its valence. An icosphere stays semi-regular (valences 5 and 6 only),
// which the Loop element needs (continuum/loop_surface.hpp): on such meshes, uniform or graded,
// its bending errs up to 124 times less than Juelicher's, but on the refined meshes, whose
// vertices of valence 7 to 11 spoil the limit surface's curvature, up to 58 times more
// (docs/validation/loop-element.md).
//
// Written here rather than taken from CGAL: its remeshers (isotropic remeshing, the surface
// mesher) change the connectivity, which is what must be kept. The method is the equilibrium of
// edge springs of stiffness 1/h (Jacobi sweeps of weighted smoothing, each followed by the
// projection evans_fung_project): in a chain of springs the tension k L is the same in every
// spring, so an edge's length scales as h at its midpoint (r-adaptive remeshing of membranes:
// Ma and Klug, J. Comput. Phys. 227, 5816, 2008).
#include "continuum/adapted_mesh.hpp"
#include "core/mesh.hpp"
#include "core/rest_shape.hpp"

namespace rbc {

struct SurfaceGradingOptions {
  int sweeps = 400;         ///< Jacobi sweeps, in [1, 100000]
  double relaxation = 0.5;  ///< fraction of the move to the weighted mean per sweep, in (0, 1]
  /// Throws rbc::InvalidParameter naming the first value out of range.
  void validate() const;
};

/// `mesh` (3 x N vertices near the Evans-Fung surface `shape`, um) with its vertices moved along
/// the surface so that edge lengths follow size_um (only its ratios matter): each sweep moves
/// vertex i to x_i + relaxation (sum_j w_ij x_j / sum_j w_ij - x_i), w_ij = 1 / h((x_i + x_j)/2),
/// then onto the surface. Deterministic (Jacobi: every vertex from the previous sweep's
/// positions). A mesh and field symmetric under a mirror of the scene stay symmetric. Throws
/// std::runtime_error if a triangle turns over (its normal against the surface's), which a
/// grading steeper than the mesh can follow causes.
TriMesh grade_on_evans_fung_surface(const TriMesh& mesh, const EvansFungShape& shape,
                                    const SizeField& size_um,
                                    const SurfaceGradingOptions& options = {});

}  // namespace rbc
