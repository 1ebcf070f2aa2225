#pragma once
// Second derivatives of the geometric measures Newton's method needs (the gradients are in
// core/geometry.hpp). Vertex-major layout: entries 3k..3k+2 belong to the k-th vertex.
#include <Eigen/Core>

#include "core/geometry.hpp"

namespace rbc {

using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector9d = Eigen::Matrix<double, 9, 1>;

/// Triangle area A = sqrt(D)/2 with D = |e1|^2 |e2|^2 - (e1.e2)^2 = |e1 x e2|^2, e1 = b - a,
/// e2 = c - a (um^2). Gradient (9, um) and Hessian (9 x 9, dimensionless):
///   dA = dD/(4 sqrt D),  d2A = d2D/(4 sqrt D) - dD dD^T/(8 D^(3/2)),
///   d2D/de1^2 = 2|e2|^2 I - 2 e2 e2^T,  d2D/de2^2 = 2|e1|^2 I - 2 e1 e1^T,
///   dD/de1 = 2|e2|^2 e1 - 2(e1.e2) e2,  d2D/de1de2 = 4 e1 e2^T - 2 e2 e1^T - 2 (e1.e2) I.
/// The triangle must be non-degenerate (D > 0).
double triangle_area_hessian(const Vec3& a, const Vec3& b, const Vec3& c, Vector9d* grad,
                             Matrix9d* hess);

/// Hessian (9 x 9, um) of the signed tetrahedron volume V = a.(b x c)/6 of core/geometry.hpp:
/// d2V/da db = -[c]_x / 6, d2V/da dc = [b]_x / 6, d2V/db dc = -[a]_x / 6 (and transposes),
/// zero diagonal blocks; [v]_x is the cross-product matrix.
Matrix9d tetra_volume_hessian(const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace rbc
