// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// In-plane hyperelastic linear triangle on a surface (MODEL.md sections 3-4; paper eq. (15),
// (17)): the energy of one element is its reference area times the membrane law's areal
// density Psi(I1, I2), evaluated at the element's constant surface deformation gradient.
//
// Kinematics by metrics (no local frames needed): with reference edges E_a = X_a - X_0 and
// current edges e_a = x_a - x_0 (a = 1, 2), the reference metric G_ab = E_a . E_b and the
// current metric g_ab = e_a . e_b, the right Cauchy-Green tensor in the reference tangent
// basis has tr C = tr(G^-1 g) and det C = det g / det G, so
//   I2 = tr(G^-1 g) - 2 = l1^2 + l2^2 - 2,   I1 = J - 1 = sqrt(det g / det G) - 1 = A/Abar - 1.
// Both invariants are invariant under rigid motions of the current triangle.
#include <Eigen/Core>

#include "core/geometry.hpp"
#include "homogenise/membrane_law.hpp"

namespace rbc {

/// Element area ratio J = A/Abar below which an element counts as collapsed: the state is
/// infeasible (energy +infinity), so a step producing it is shortened. Same threshold as
/// the discrete network's collapsed face (discrete/network.hpp kCollapsedFaceRatio).
inline constexpr double kCollapsedElementRatio = 1e-3;

/// Stress-free reference of one element: inverse reference metric G^-1 (1/um^2) and
/// reference area Abar (um^2).
struct MembraneReference {
  Eigen::Matrix2d metric_inverse = Eigen::Matrix2d::Identity();
  double area_um2 = 0.0;
};

/// Reference of the triangle (X0, X1, X2) (um). Throws std::invalid_argument for a
/// degenerate triangle (zero area): a physical precondition, not an internal invariant.
MembraneReference make_membrane_reference(const Vec3& x0, const Vec3& x1, const Vec3& x2);

/// The two invariants of paper eq. (17), dimensionless.
struct SurfaceInvariants {
  double i1 = 0.0;  ///< J - 1
  double i2 = 0.0;  ///< tr C - 2
};
SurfaceInvariants surface_invariants(const MembraneReference& ref, const Vec3& x0, const Vec3& x1,
                                     const Vec3& x2);

using ElementGradient = Eigen::Matrix<double, 9, 1>;
using ElementHessian = Eigen::Matrix<double, 9, 9>;

/// Element energy E = Abar Psi(I1, I2) (pN um), and optionally its gradient dE/d(x0,x1,x2)
/// (9, pN, vertex-major) and Hessian (9 x 9, pN/um):
///   dE   = Abar (Psi_1 dJ + Psi_2 dI2),
///   d2E  = Abar (Psi_11 dJ dJ^T + Psi_12 (dJ dI2^T + dI2 dJ^T) + Psi_22 dI2 dI2^T
///                + Psi_1 d2J + Psi_2 d2I2),
/// with d2I2 = 2 G^-1 (x) I3 in edge variables (constant) and J = sqrt(det g)/(2 Abar).
/// Returns +infinity (derivatives untouched) when J < kCollapsedElementRatio or the law
/// is infinite there (e.g. a link direction at Lmax for the full WLC law).
double membrane_element_energy(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                               const Vec3& x0, const Vec3& x1, const Vec3& x2,
                               ElementGradient* grad = nullptr, ElementHessian* hess = nullptr);

/// The element Hessian split as d2E = rest + area_coef d2A (d2A: core triangle area
/// Hessian, discrete/element_hessian.hpp; area_coef = Psi_1 in pN/um), so a caller adding
/// other multiples of d2A (area constraint, bending face terms) evaluates d2A once. Same
/// return value and infeasibility rule as membrane_element_energy (rest, area_coef untouched
/// when +infinity).
double membrane_element_hessian_parts(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                                      const Vec3& x0, const Vec3& x1, const Vec3& x2,
                                      ElementHessian& rest, double& area_coef);

/// Principal surface tensions (pN/um) of the Cauchy surface stress of paper Sec. 4.1,
/// tau = 2/J Psi_2 F F^T + Psi_1 P: tau_i = 2 Psi_2 l_i^2 / J + Psi_1, largest first,
/// with l_i^2 the eigenvalues of C. NaN-free: +infinity where the law is infinite.
struct PrincipalTensions {
  double t1 = 0.0, t2 = 0.0;
};
PrincipalTensions principal_tensions(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                                     const Vec3& x0, const Vec3& x1, const Vec3& x2);

}  // namespace rbc
