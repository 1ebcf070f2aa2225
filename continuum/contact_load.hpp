// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Bead load of the optical-tweezers scene integrated exactly over a contact region that does
// not snap to the mesh (MODEL.md section 2, "Optical tweezers").
//
// The contact region of the +x bead is the cap {X on the rest surface : X_x >= c+} of the
// piecewise-linear rest surface, with the plane c+ chosen so that the cap's area is the
// prescribed fraction of the total area (5 % by default, MODEL.md); likewise {X_x <= c-} at the
// -x bead. The bead's total force F acts as a uniform traction t = F / A_cap e_x on the cap
// (the by-area rule of discrete/tweezers.hpp, taken to the continuum). Its consistent nodal
// forces on linear triangles are
//   f_i = (F / A_cap) integral_{cap} N_i dA    (N_i the linear shape function of vertex i),
// integrated exactly: each triangle is clipped against the half-space (Sutherland-Hodgman in
// barycentric coordinates), the clipped polygon is split into a fan of triangles, and a linear
// function integrates over a triangle to its area times its value at the centroid. Since
// sum_i N_i = 1, sum_i f_i = F to round-off on any mesh, and f_i is a continuous (piecewise
// quadratic) function of the plane and of the rest positions: the load does not jump when a
// vertex crosses the region's edge, as the vertex patch's does.
#include "core/geometry.hpp"
#include "core/mesh.hpp"
#include "discrete/tweezers.hpp"

namespace rbc {

/// The part of a triangle on one side of the plane x = plane_x_um: its area (um^2) and the
/// integrals of the three linear shape functions over it (um^2; they sum to the area).
struct ClippedTriangle {
  double area_um2 = 0.0;
  Vec3 shape_integral_um2 = Vec3::Zero();
};

/// Clips triangle (x0, x1, x2) (um) against the half-space side * (X_x - plane_x_um) >= 0
/// (side = +1: the part with X_x >= plane; side = -1: X_x <= plane) and integrates the shape
/// functions over the clipped polygon exactly. std::invalid_argument unless side is +-1.
ClippedTriangle clip_triangle(const Vec3& x0, const Vec3& x1, const Vec3& x2, double plane_x_um,
                              int side);

/// Area (um^2) of the part of the mesh surface with side * (X_x - plane_x_um) >= 0.
double cap_area(const Positions& x, const Topology& topo, double plane_x_um, int side);

/// The plane whose cap on `side` has the given area (um^2; in (0, total area), else
/// std::invalid_argument): the cap area is continuous and monotone in the plane, solved by
/// bisection to the last bit of the plane position.
double cap_plane_for_area(const Positions& x, const Topology& topo, double area_um2, int side);

/// The exactly integrated bead load as a TweezerPatch (the form discrete/tweezers.hpp's
/// tweezers_energy, the mirror-symmetry detection and the solvers take): every vertex of a
/// triangle that meets a cap, with share_i = +-integral_{cap} N_i dA / A_cap (each side sums to
/// +-1 to round-off); area_plus_um2, area_minus_um2 the caps' areas.
struct ContactLoad {
  TweezerPatch patch;
  double plane_plus_um = 0.0, plane_minus_um = 0.0;  ///< c+ and c- (rest x, um)
};

/// The load of the caps X_x >= plane_plus_um and X_x <= plane_minus_um of the rest mesh.
/// std::invalid_argument if either cap is empty.
ContactLoad contact_load_at(const Positions& rest, const Topology& topo, double plane_plus_um,
                            double plane_minus_um);

/// The load of caps of area contact_fraction x total rest area at each end (MODEL.md: 5 %,
/// ~6.7 um^2 on the default cell). rbc::InvalidParameter unless contact_fraction is finite and
/// in (0, 0.5) (TweezersParameters::validate's range).
ContactLoad exact_contact_load(const Positions& rest, const Topology& topo,
                               double contact_fraction);

}  // namespace rbc
