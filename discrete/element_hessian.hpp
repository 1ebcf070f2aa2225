#pragma once
// Second derivatives of the per-face geometric measures that the network's Newton-type
// Hessian (discrete/network_hessian.hpp) needs; the values and gradients are the
// core/geometry.hpp kernels. Vertex-major layout: entries 3k..3k+2 belong to vertex k of
// the face (a, b, c).
#include <Eigen/Core>

#include "core/geometry.hpp"

namespace rbc {

using FaceMatrix = Eigen::Matrix<double, 9, 9>;

/// Hessian (9 x 9, dimensionless) of the triangle area A = |n|/2, n = a x b + b x c + c x a:
/// with the Jacobians dn/dx_k = [e_k]_x (e_k the edge opposite vertex k: e_a = c - b,
/// e_b = a - c, e_c = b - a), nh = n/|n| and the projector P = I - nh nh^T,
///   d2A/dx_k dx_l = (1/(2|n|)) [e_k]_x^T P [e_l]_x + (1/2) s_kl [nh]_x,
/// s_kl = -1 for the cyclic pairs (a,b), (b,c), (c,a), +1 for (b,a), (c,b), (a,c), 0 on the
/// diagonal (the bilinear part of n). The triangle must be non-degenerate.
FaceMatrix face_area_hessian(const Vec3& a, const Vec3& b, const Vec3& c);

/// Hessian (9 x 9, um) of the signed tetrahedron volume V = a.(b x c)/6 (core/geometry.hpp):
/// d2V/da db = -[c]_x/6, d2V/db dc = -[a]_x/6, d2V/dc da = -[b]_x/6, transposes below the
/// diagonal, zero diagonal blocks; [v]_x is the cross-product matrix ([v]_x w = v x w).
FaceMatrix face_volume_hessian(const Vec3& a, const Vec3& b, const Vec3& c);

using HingeMatrix = Eigen::Matrix<double, 12, 12>;

/// Hessian (12 x 12, vertex-major a, b, c, d; 1/um) of one hinge's q = |b - a| theta
/// (bending_energy.hpp hinge_length_angle; theta core/geometry.hpp's dihedral_angle), by
/// forward-mode automatic differentiation (Eigen AutoDiff, 12 directions) of the analytic
/// gradient, so exact to rounding. Writes the gradient (3 x 4) too; returns q (um).
double hinge_length_angle_second(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                 Eigen::Matrix<double, 3, 4>* grad, HingeMatrix* hess);

/// Replaces the symmetric matrix h by its projection onto the positive semidefinite cone
/// (negative eigenvalues set to zero), as in projected Newton (Teran et al. 2005).
template <int K>
void project_positive_semidefinite(Eigen::Matrix<double, K, K>& h);

}  // namespace rbc
