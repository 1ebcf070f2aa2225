// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/moduli.hpp"

#include <cmath>

#include "core/units.hpp"

namespace rbc {

double LinearModuli::young_pN_per_um() const {
  return 4.0 * K_pN_per_um * mu_pN_per_um / (K_pN_per_um + mu_pN_per_um);
}
double LinearModuli::poisson() const {
  return (K_pN_per_um - mu_pN_per_um) / (K_pN_per_um + mu_pN_per_um);
}

LinearModuli closed_form_moduli(const WlcDensity& w, const StericParameters& s) {
  s.validate();
  const double v1 = derivative_at_rest(w, 1), v2 = derivative_at_rest(w, 2);
  LinearModuli m;
  m.mu_pN_per_um = 3.0 * v1 + 1.5 * v2;
  m.K_pN_per_um = 3.0 * (1.0 + s.eta + s.q - s.q * s.eta) / (1.0 + s.eta) * v1 + 3.0 * v2;
  return m;
}

LinearModuli closed_form_moduli(const WlcParameters& p, const StericParameters& s) {
  return closed_form_moduli(make_wlc_density(p), s);
}

LinearModuli paper_explicit_moduli(const WlcParameters& p, const StericParameters& s) {
  p.validate();
  s.validate();
  const double kT = units::thermal_energy_pNum(p.temperature_K);
  const double L = p.lbar_um, Lm = p.lmax_um, per = p.persistence_um;
  const double d = Lm - L;
  const double r3 = units::sqrt3 * kT;
  LinearModuli m;
  m.mu_pN_per_um = r3 * (-16 * L * L * L + 51 * L * L * Lm - 57 * L * Lm * Lm + 24 * Lm * Lm * Lm) /
                   (16 * per * Lm * d * d * d);
  m.K_pN_per_um = 3 * (1 + s.eta + s.q - s.q * s.eta) / (1 + s.eta) * r3 *
                      (4 * L * L - 9 * L * Lm + 6 * Lm * Lm) / (12 * per * Lm * d * d) +
                  r3 * L * (3 * Lm - L) / (8 * per * d * d * d);
  return m;
}

}  // namespace rbc
