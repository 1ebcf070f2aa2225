// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The anisotropic cell-problem density of the perfect hexagonal lattice (MODEL.md section 3;
// Hartmann 2008 eq. (11), Theorem 3):
//   Psi(F) = 1/2 sum_{i=1..6} V(xi_i^T F^T F xi_i) + 2 C / (det(F)^q + eta)      [pN/um]
// with unit link directions xi_i at angles phi + i pi/3 (phi = lattice orientation).
// Since xi_{i+3} = -xi_i, the sum is sum_{i=0..2} V(z_i). Gradient:
//   dPsi/dF = sum_{i=0..2} 2 V'(z_i) F xi_i xi_i^T + s'(J) J F^{-T},   s(J) = 2C/(J^q + eta).
// For the quadratic V (order2) it is isotropic; for order 3, 4 and the full WLC it has the
// lattice's 60-degree symmetry only. Returns +infinity for det F <= 0 or a link at Lmax.
#include <Eigen/Core>
#include <functional>

#include "discrete/steric_energy.hpp"
#include "discrete/wlc.hpp"

namespace rbc {

/// Psi(F) of the lattice rotated by phi (rad); `w.expansion` selects V. grad (2x2) is
/// written when non-null and Psi is finite. C is the steric constant (pN/um).
double lattice_density(const WlcDensity& w, double C, const StericParameters& s,
                       const Eigen::Matrix2d& F, double phi = 0.0, Eigen::Matrix2d* grad = nullptr);

/// Mean of f over one period [0, period) by GSL's adaptive Gauss-Kronrod quadrature (QAG,
/// 61-point rule) to relative tolerance rel_tol: the reference orientation average that
/// the closed Appendix A forms and the trapezoid tables are checked against. Throws
/// std::runtime_error if GSL reports failure.
double average_over_angle(const std::function<double(double)>& f, double period,
                          double rel_tol = 1e-12);

}  // namespace rbc
