// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Canham-Helfrich bending of the Loop subdivision limit surface (continuum/loop_surface.hpp),
// the bending of Cirak, Ortiz and Schroeder's C1 subdivision shell elements (Int. J. Numer.
// Meth. Engng 47, 2039, 2000) with the Helfrich law of MODEL.md section 2 (paper eq. (7)):
//   F_CH = (kappa/2) int (H - H0)^2 dA   (pN um),  H = C1 + C2 (1/um, sum convention)
// on the smooth surface itself, with no discrete curvature operator: at a point with
// parameters (v, w), tangents x_v, x_w, second derivatives x_vv, x_vw, x_ww (um), metric
// g_ab = x_a . x_b, outward normal n = x_v x x_w / J, J = |x_v x x_w| (um^2) and second
// fundamental form b_ab = x_ab . n,
//   H = -(g_ww b_vv - 2 g_vw b_vw + g_vv b_ww) / J^2
// (H = 2/R on a sphere of radius R), and dA = J dv dw. The integral is the quadrature of
// loop_quadrature. The Gaussian-curvature term is a topological constant on a closed surface
// (Gauss-Bonnet) and is left out, as in the Juelicher discretisation.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <vector>

#include "continuum/loop_surface.hpp"
#include "core/geometry.hpp"
#include "discrete/bending_energy.hpp"

namespace rbc {

/// The surface's derivatives at one point, in the order x_v, x_w, x_vv, x_vw, x_ww (um).
using LoopJet = std::array<Vec3, 5>;
using LoopJetGradient = Eigen::Matrix<double, 15, 1>;
using LoopJetHessian = Eigen::Matrix<double, 15, 15>;

/// The jet at a quadrature point from the control points x (3 x N, um).
LoopJet loop_jet(const LoopBasis& basis, const Positions& x);

/// Mean curvature H = C1 + C2 (1/um) of the surface with this jet.
double loop_mean_curvature(const LoopJet& jet);

/// Bending energy density per unit parameter area, e = (kappa/2) (H - H0)^2 J (pN um), and
/// optionally its gradient (pN) and Hessian (pN/um) in the 15 jet components (vector-major:
/// x_v's x, y, z, then x_w's, ...), in closed form by the chain rule through the primitives
/// g_ab, J^2 and x_ab . (x_v x x_w). Returns +infinity (derivatives untouched) where J = 0.
double loop_helfrich_density(const BendingParameters& params, const LoopJet& jet,
                             LoopJetGradient* grad = nullptr, LoopJetHessian* hess = nullptr);

/// F_CH of the limit surface of control points x (3 x N, um) by the quadrature q (pN um);
/// gradient (3 x N, pN, accumulated into grad) and Hessian (3N x 3N, pN/um, vertex-major
/// dofs as flat(); overwritten) when asked.
double loop_helfrich_energy(const std::vector<LoopQuadraturePoint>& q, const Positions& x,
                            const BendingParameters& params, Positions* grad = nullptr,
                            Eigen::SparseMatrix<double>* hess = nullptr);

/// Area of the limit surface by the quadrature q (um^2).
double loop_surface_area(const std::vector<LoopQuadraturePoint>& q, const Positions& x);

}  // namespace rbc
