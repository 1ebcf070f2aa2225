// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Extent of the smooth surface a triangle mesh samples, rather than of its vertices: the
// optical-tweezers diameters D_A (along x) and D_T (largest extent in the y-z plane; see
// core/geometry.hpp measure_diameters) of the continuum's reconstructed surface.
//
// Reconstruction: a local quadric fit (the degree-2 osculating jet of Cazals and Pouget,
// Comput. Aided Geom. Des. 22 (2005) 121). For a direction u, let v be the vertex with the
// largest u . x_v. Over its 1-ring (its 2-ring where the 1-ring leaves the fit undetermined),
// in an orthonormal frame (e1, e2, u) at x_v,
// the height h = u . (x - x_v) is fitted by least squares as a quadric through x_v in the
// in-plane coordinates (a, b) = (e1 . (x - x_v), e2 . (x - x_v)):
//   h(a, b) = q1 a + q2 b + q3 a^2 + q4 a b + q5 b^2,
// and the support value of the surface along u is u . x_v + max h, the maximum at the
// stationary point of the quadric (its Hessian negative definite). A degree-2 fit of points on
// a smooth surface is exact to O(h^3) over its stencil of radius ~h, so the support value
// is too (the vertex maximum's error is O(h^2): kappa d^2 / 2 for a vertex a distance d <= h
// from the extremal point on a surface of curvature kappa). The surface must be a graph over
// the plane normal to u across the stencil (true once the mesh resolves the curvature there);
// where the fit has no maximum inside its stencil, the vertex value is kept. Through x_v, the
// fit adds only -g.H^-1 g / 2 >= 0 to the vertex value, which stays small at an unresolved tip
// (a spike of a few vertices, g ~ 0), where a fit free at x_v would overshoot the apex.
#include "core/geometry.hpp"
#include "core/mesh.hpp"

namespace rbc {

/// The support value of the reconstructed surface along the unit direction u (um): max of
/// u . p over the fitted surface near the extremal vertex.
struct SurfaceSupport {
  double value_um = 0.0;  ///< u . p at the fitted maximum (or at the vertex if !fitted)
  Vec3 point = Vec3::Zero();
  int vertex = -1;      ///< the extremal vertex the fit is centred on
  bool fitted = false;  ///< false: the fit had no maximum within its stencil
};
SurfaceSupport surface_support(const Positions& x, const Topology& topo, const Vec3& u);

/// D_A = support(e_x) + support(-e_x) and D_T = the largest support(u) + support(-u) over unit
/// u in the y-z plane (golden-section search within 0.25 rad of the vertices' widest
/// direction, to 1e-9 rad), of the quadric-fitted surface (um).
Diameters surface_diameters(const Positions& x, const Topology& topo);

}  // namespace rbc
