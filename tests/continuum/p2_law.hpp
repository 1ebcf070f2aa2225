// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// An independent closed-form p = 2 membrane law for the continuum tests, written straight
// from MODEL.md section 3 (paper Sec. 3.4):
//   Psi = 3/2 V'(1) I2 + 3/16 V''(1) (4 I2 - 8 I1 + 3 I2^2 - 4 I1^2) + 2 C/((1 + I1)^q + eta)
// with V'(1), V''(1) from discrete/wlc.hpp and C from discrete/steric_energy.hpp. The tests
// exercise the elements through the IsotropicMembraneLaw contract only, so they do not
// depend on homogenise/'s implementation.
#include <limits>

#include "discrete/steric_energy.hpp"
#include "discrete/wlc.hpp"
#include "homogenise/membrane_law.hpp"

namespace rbc::testing {

inline IsotropicMembraneLaw closed_form_p2_law(const WlcParameters& wp = {},
                                               const StericParameters& sp = {}) {
  const WlcDensity w = make_wlc_density(wp, WlcExpansion::order2);
  const double v1 = derivative_at_rest(w, 1), v2 = derivative_at_rest(w, 2);
  const double c = steric_constant(w, sp);
  IsotropicMembraneLaw law;
  law.name = "test closed-form p=2";
  law.evaluate = [=](double i1, double i2) {
    InvariantDerivatives d;
    const double jac = 1.0 + i1;
    if (!(jac > 0)) {
      d.psi = std::numeric_limits<double>::infinity();
      return d;
    }
    const StericDensity s = steric_density(c, sp, jac);
    d.psi = 1.5 * v1 * i2 + 3.0 / 16.0 * v2 * (4 * i2 - 8 * i1 + 3 * i2 * i2 - 4 * i1 * i1) + s.v;
    d.d1 = 3.0 / 16.0 * v2 * (-8 - 8 * i1) + s.dv;
    d.d2 = 1.5 * v1 + 3.0 / 16.0 * v2 * (4 + 6 * i2);
    d.d11 = -1.5 * v2 + s.d2v;
    d.d12 = 0.0;
    d.d22 = 18.0 / 16.0 * v2;
    return d;
  };
  return law;
}

}  // namespace rbc::testing
