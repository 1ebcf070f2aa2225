// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Isotropic invariant-form densities Psi(I1, I2) of the homogenised hexagonal network
// (MODEL.md section 3; Hartmann 2008 Sec. 3.4 and Appendix A), offered to continuum/
// through the IsotropicMembraneLaw contract (homogenise/membrane_law.hpp).
//
// Geometry behind every law here. For C = F^T F with principal values l1^2 >= l2^2 and a
// unit link direction xi at angle theta to the first principal axis,
//   xi^T C xi - 1 = a + b cos(2 theta),   a = I2/2,   b^2 = B = (I2 + 2)^2/4 - (1 + I1)^2,
// so the lattice sum over the six directions, averaged over the lattice angle phi, is
//   Psi(I1, I2) = 1/2 mean_phi sum_i V(xi_i^T C xi_i) + s(J) = 3 G(a, B) + s(1 + I1),
//   G(a, B) = (1/pi) int_0^pi V(1 + a + b cos t) dt,   s(J) = 2 C/(J^q + eta).
// G is even in b, hence smooth in B, and by parts
//   G_B = 1/2 mean[V''(u) sin^2 t],  G_aB = 1/2 mean[V'''(u) sin^2 t],
//   G_BB = 1/12 mean[V''''(u) sin^4 t],  u = 1 + a + b cos t,
// so all derivatives stay finite at the isotropic state b = 0.
//
// * Taylor laws (p = 2, 3, 4): V replaced by its Taylor polynomial about z = 1; then
//   mean[(a + b cos t)^j] = a^j + j(j-1)/4 a^(j-2) B + j(j-1)(j-2)(j-3)/64 a^(j-4) B^2,
//   which is 1/6 of the Appendix A sums (the paper's j = 3, 4 orientation averages; for
//   j <= 2 no average is needed: Psi_2 equals the un-averaged lattice density, isotropic).
//   Unlike Sec. 3.4, constants are kept (Psi(0, 0) = 3 V(1) + 2C/(1 + eta)), so
//   Psi_p equals the lattice density itself, not just up to a constant. The paper writes
//   the steric term as 2C/(I1^q + eta); the lattice energy (11) requires J^q = (1 + I1)^q.
// * Full law: exact WLC V, averaged by the periodic trapezoid rule in t (which is the
//   average over copies of the lattice rotated by pi/(3K)), K in {16, ..., 1024} chosen
//   per call from the distance of the pole z = 1/x0^2 to the real t axis,
//   K rho >= 20, rho = min(acosh((1/x0^2 - 1 - a)/b), acosh((1 + a)/b)) (the pole of V at
//   Lmax and the branch point of V at z = 0): relative error ~ exp(-2 K rho) < 1e-15,
//   except where K = 1024 saturates: within a relative ~2e-4 (in z = l1^2) of the
//   divergence, or l2/l1 below ~0.01 (error exp(-2 K rho) then grows smoothly). Psi = +infinity
//   once any direction reaches Lmax (l1 >= 1/x0), and for J <= 0.
// Units: Psi and its derivatives in pN/um.
#include <Eigen/Core>

#include "discrete/steric_energy.hpp"
#include "discrete/wlc.hpp"
#include "homogenise/membrane_law.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {

/// I1 = det F - 1, I2 = tr(F^T F) - 2 of a 2x2 deformation gradient (paper eq. (17)).
struct Invariants {
  double i1 = 0, i2 = 0;
};
Invariants invariants(const Eigen::Matrix2d& F);

/// First Piola-Kirchhoff stress (pN/um) of an invariant law at F:
///   P = dPsi/dF = d1 J F^{-T} + 2 d2 F.
Eigen::Matrix2d first_piola(const Eigen::Matrix2d& F, const InvariantDerivatives& d);

/// The law for `expansion` (full, order2, order3, order4) built on the density w (whose
/// own expansion field is ignored) and the stress-free steric constant C(w, s).
/// Evaluation allocates nothing; the full law's quadrature tables are built here once.
/// Throws std::invalid_argument for invalid steric parameters.
IsotropicMembraneLaw make_membrane_law(const WlcDensity& w, const StericParameters& s,
                                       WlcExpansion expansion);
IsotropicMembraneLaw make_membrane_law(const WlcParameters& p, const StericParameters& s,
                                       WlcExpansion expansion);

/// Linear moduli read off a law at the rest state from its invariant derivatives:
///   pure shear F = diag(1+s, 1-s):     4 mu = d^2Psi/ds^2 = 4 d2 - 2 d1,
///   equibiaxial F = (1+s) I:           4 K  = 2 d1 + 4 d2 + 4 d11 + 16 d12 + 16 d22.
/// (pN/um). Equal to the closed forms for every order, since all laws agree to second order.
LinearModuli law_moduli(const IsotropicMembraneLaw& law);

}  // namespace rbc
