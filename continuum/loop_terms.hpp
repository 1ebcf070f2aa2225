// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The pointwise terms of the Loop element (continuum/loop_surface.hpp) other than bending
// (continuum/loop_bending.hpp), each a density per unit parameter area at one quadrature point
// of the limit surface with its exact gradient and Hessian in the point's jet, and the one
// assembly that maps a jet's derivatives to the control points.
//
//  - In-plane law (MODEL.md sections 3-4; paper eq. (15), (17)): e = Jbar Psi(I1, I2) (pN um),
//    I1 = J / Jbar - 1, I2 = tr(G^-1 g) - 2, with g_ab = x_a . x_b the metric of the current
//    limit surface, G (1/um^2 inverse) and Jbar = sqrt(det G) (um^2) the rest surface's at the
//    same parameters, J = |x_v x x_w|. The membrane element of continuum/membrane_element.hpp
//    on the smooth surface instead of the flat triangle.
//  - Area: a = J (um^2). Volume (divergence theorem): v = x . (x_v x x_w) / 3 (um^3).
// All derivatives in closed form (J through J^2 = |x_v x x_w|^2, loop_cross_norm2); the law's by
// its own contract (homogenise/membrane_law.hpp).
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "continuum/loop_surface.hpp"
#include "core/geometry.hpp"
#include "homogenise/membrane_law.hpp"

namespace rbc {

/// The rest surface at one quadrature point: G^-1 (1/um^2) and Jbar (um^2).
struct LoopMembraneReference {
  Eigen::Matrix2d metric_inverse = Eigen::Matrix2d::Identity();
  double jacobian_um2 = 0.0;
};
/// The reference from the rest tangents x_v, x_w (um). Throws rbc::InvalidParameter where they
/// are parallel (a degenerate rest surface).
LoopMembraneReference make_loop_membrane_reference(const Vec3& xv, const Vec3& xw);

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector9d = Eigen::Matrix<double, 9, 1>;

/// e = Jbar Psi(I1, I2) (pN um) of the tangents (x_v, x_w) (um), with its gradient (pN) and
/// Hessian (pN/um) in (x_v, x_w) when asked. +infinity (derivatives untouched) where J / Jbar <
/// kCollapsedElementRatio or the law is infinite.
double loop_membrane_density(const IsotropicMembraneLaw& law, const LoopMembraneReference& ref,
                             const Vec3& xv, const Vec3& xw, Vector6d* grad = nullptr,
                             Matrix6d* hess = nullptr);

/// J^2 = |x_v x x_w|^2 (um^4) with its gradient and Hessian in (x_v, x_w): with m = x_v x x_w,
/// dJ^2 = 2 (x_w x m, m x x_v), d2J^2 = 2 Dm' Dm + 2 m . d2m (Dm = (-[x_w]x, [x_v]x)).
double loop_cross_norm2(const Vec3& xv, const Vec3& xw, Vector6d* grad = nullptr,
                        Matrix6d* hess = nullptr);

/// a = J = |x_v x x_w| (um^2) with its gradient and Hessian in (x_v, x_w).
double loop_area_density(const Vec3& xv, const Vec3& xw, Vector6d* grad = nullptr,
                         Matrix6d* hess = nullptr);

/// v = x . (x_v x x_w) / 3 (um^3) with its gradient and Hessian in (x, x_v, x_w).
double loop_volume_density(const Vec3& x, const Vec3& xv, const Vec3& xw, Vector9d* grad = nullptr,
                           Eigen::Matrix<double, 9, 9>* hess = nullptr);

/// Adds one point's term to the control points' gradient and Hessian: the term depends on the
/// jet rows first_row .. first_row + rows - 1 of the basis (0 position, 1-2 tangents, 3-5
/// second derivatives), each a 3-vector linear in the control points; local_grad (3 rows) and
/// local_hess (3 rows x 3 rows) are its derivatives in them, already times the quadrature
/// weight. grad: 3 x N (accumulated); hess: triplets of the 3N x 3N matrix (vertex-major).
void add_loop_point_derivatives(const LoopBasis& basis, int first_row, int rows,
                                const Eigen::VectorXd& local_grad,
                                const Eigen::MatrixXd* local_hess, Positions* grad,
                                std::vector<Eigen::Triplet<double>>* hess);

}  // namespace rbc
