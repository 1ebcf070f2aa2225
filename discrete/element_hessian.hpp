// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Second derivatives of the per-element geometric measures (triangle area, tetrahedron
// volume, hinge length x angle) that every Newton-type Hessian of the project uses: the
// discrete network preconditioner (discrete/network_hessian.hpp), the Juelicher bending
// Hessian (discrete/bending_energy.hpp) and the continuum elements and constraints
// (continuum/). The values and first derivatives are the core/geometry.hpp kernels except
// where stated. Vertex-major layout: entries 3k..3k+2 belong to vertex k of the element.
#include <Eigen/Core>

#include "core/geometry.hpp"

namespace rbc {

using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;

/// Triangle area A = sqrt(D)/2 with D = |e1|^2 |e2|^2 - (e1.e2)^2 = |e1 x e2|^2, e1 = b - a,
/// e2 = c - a (um^2). Gradient (9, um) when requested, dA = dD/(4 sqrt D) with
/// dD/de1 = 2|e2|^2 e1 - 2(e1.e2) e2, dD/de2 = 2|e1|^2 e2 - 2(e1.e2) e1. Hessian (9 x 9,
/// dimensionless) when requested: with dn/dx_k = [e_k]_x (n = e1 x e2, e_k the edge
/// opposite vertex k: e_a = c - b, e_b = a - c, e_c = b - a), nh = n/|n|, P = I - nh nh^T,
///   d2A/dx_k dx_l = (1/(2|n|)) [e_k]_x^T P [e_l]_x + (1/2) s_kl [nh]_x,
/// s_kl = -1 for the cyclic pairs (a,b), (b,c), (c,a), +1 for (b,a), (c,b), (a,c), 0 on the
/// diagonal (the bilinear part of n); [v]_x is the cross-product matrix. The triangle must
/// be non-degenerate (D > 0).
double triangle_area_hessian(const Vec3& a, const Vec3& b, const Vec3& c, Vector9d* grad,
                             Matrix9d* hess);

/// Hessian (9 x 9, um) of the signed tetrahedron volume V = a.(b x c)/6 (core/geometry.hpp
/// tetra_volume): d2V/da db = -[c]_x/6, d2V/db dc = -[a]_x/6, d2V/dc da = -[b]_x/6,
/// transposes below the diagonal, zero diagonal blocks; [v]_x is the cross-product matrix
/// ([v]_x w = v x w).
Matrix9d tetra_volume_hessian(const Vec3& a, const Vec3& b, const Vec3& c);

/// q = |b - a| theta(a, b, c, d) (um) of the hinge (a, b) with opposite vertices c (in the
/// face traversing a -> b) and d; theta is core/geometry.hpp's exterior dihedral angle
/// (Juelicher 1996's integrated mean curvature per edge). Gradient (3 x 4 columns a, b, c, d;
/// dimensionless) and Hessian (12 x 12, vertex-major a, b, c, d; 1/um) in closed form, the
/// chain rule of the analytic gradient (Bridson et al. 2003's dtheta; cf. Tamstorf & Grinspun
/// 2013): with L = |e|, e = b - a, m0 = e x (c - a), m1 = (a - b) x (d - b),
///   dtheta/dc = -L m0/|m0|^2,  dtheta/dd = -L m1/|m1|^2,
///   dtheta/da = -(1 - t_c) dtheta/dc - (1 - t_d) dtheta/dd,
///   dtheta/db = -t_c dtheta/dc - t_d dtheta/dd,   t_k = (k - a).e/L^2,
///   d(-L m/|m|^2) = -(m/|m|^2) dL - (L/|m|^2)(I - 2 m m^T/|m|^2) dm,
///   d2q = L d2theta + theta d2L + dL dtheta^T + dtheta dL^T,  d2L = +-(I - e e^T/L^2)/L,
/// symmetrised (the exact Hessian is symmetric; the chain rule is so up to rounding). Equal
/// to hinge_length_angle_hessian_autodiff to rounding; value and gradient agree with
/// bending_energy.hpp's hinge_length_angle to rounding. The hinge must be non-degenerate
/// (L > 0, both faces of positive area).
double hinge_length_angle_hessian(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                  Eigen::Matrix<double, 3, 4>* grad, Matrix12d* hess);

/// The same q, gradient and Hessian by forward-mode automatic differentiation (Eigen
/// AutoDiff, 12 directions) of the analytic gradient: exact to rounding, several times slower;
/// the independent reference the closed form is tested against.
double hinge_length_angle_hessian_autodiff(const Vec3& a, const Vec3& b, const Vec3& c,
                                           const Vec3& d, Eigen::Matrix<double, 3, 4>* grad,
                                           Matrix12d* hess);

/// Replaces the symmetric matrix h by its projection onto the positive semidefinite cone
/// (negative eigenvalues set to zero), as in projected Newton (Teran et al. 2005). Instantiated
/// for K = 3, 9, 12 and Eigen::Dynamic.
template <int K>
void project_positive_semidefinite(Eigen::Matrix<double, K, K>& h);

}  // namespace rbc
