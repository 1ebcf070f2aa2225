// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The contract between a constitutive law and the continuum finite elements (STYLE.md 4):
// an isotropic areal strain-energy density Psi(I1, I2) with its first and second
// derivatives. Closed-form Taylor laws and the orientation-averaged full WLC law are all
// of this form, so continuum/ never needs to know where a law came from.
//
// Invariants of the surface deformation gradient F (paper eq. (17)):
//   I1 = J - 1 = l1 l2 - 1,   I2 = tr(F^T F) - 2 = l1^2 + l2^2 - 2.
#include <functional>
#include <string>

namespace rbc {

/// Psi and its derivatives w.r.t. (I1, I2), all in pN/um (energy per reference area).
struct InvariantDerivatives {
  double psi = 0;
  double d1 = 0, d2 = 0;             ///< dPsi/dI1, dPsi/dI2
  double d11 = 0, d12 = 0, d22 = 0;  ///< second derivatives
};

/// An isotropic membrane law. evaluate(I1, I2) returns psi = +infinity outside the law's
/// domain (J <= 0, or a link direction stretched to Lmax for the full WLC law).
struct IsotropicMembraneLaw {
  std::string name;
  std::function<InvariantDerivatives(double i1, double i2)> evaluate;
};

}  // namespace rbc
