// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/wlc.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/units.hpp"
#include "core/validation.hpp"

namespace rbc {
namespace {

/// Truncated power series a_0 + a_1 d + ... + a_4 d^4 (jet) for exact Taylor data.
struct Jet {
  std::array<double, 5> c{};
};
Jet operator*(const Jet& a, const Jet& b) {
  Jet r;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; i + j < 5; ++j) r.c[i + j] += a.c[i] * b.c[j];
  return r;
}
Jet operator*(double s, Jet a) {
  for (auto& v : a.c) v *= s;
  return a;
}
Jet operator+(Jet a, const Jet& b) {
  for (int i = 0; i < 5; ++i) a.c[i] += b.c[i];
  return a;
}
Jet reciprocal(const Jet& a) {  // 1/a by the recursion r_n = -(sum_{k>=1} a_k r_{n-k})/a_0
  Jet r;
  r.c[0] = 1.0 / a.c[0];
  for (int n = 1; n < 5; ++n) {
    double s = 0;
    for (int k = 1; k <= n; ++k) s += a.c[k] * r.c[n - k];
    r.c[n] = -s / a.c[0];
  }
  return r;
}

/// Taylor coefficients of V(1 + d) = prefactor * phi(x0 sqrt(1 + d)).
std::array<double, 5> taylor_at_rest(double prefactor, double x0) {
  // sqrt(1 + d) = 1 + d/2 - d^2/8 + d^3/16 - 5 d^4/128
  Jet x;
  x.c = {x0, x0 / 2, -x0 / 8, x0 / 16, -5 * x0 / 128};
  const Jet x2 = x * x, x3 = x2 * x;
  Jet one_minus_x = -1.0 * x;
  one_minus_x.c[0] += 1.0;
  const Jet phi = (3.0 * x2 + (-2.0) * x3) * reciprocal(one_minus_x);
  return (prefactor * phi).c;
}

}  // namespace

void WlcParameters::validate() const {
  const double nm_per_um = 1.0 / units::um_per_nm;  // messages in the user's units
  require_finite_in_range("Lbar (rest length)", "nm", lbar_um * nm_per_um, 0.0, kMaxWlcLength_nm);
  require_finite_in_range("Lmax (contour length, > Lbar)", "nm", lmax_um * nm_per_um,
                          lbar_um * nm_per_um, kMaxWlcLength_nm);
  require_finite_in_range("persistence length", "nm", persistence_um * nm_per_um, 0.0,
                          kMaxWlcLength_nm);
  require_finite_in_range("temperature", "K", temperature_K, 0.0, kMaxTemperature_K);
}

std::string to_string(WlcExpansion e) {
  switch (e) {
    case WlcExpansion::full:
      return "full";
    case WlcExpansion::order2:
      return "2";
    case WlcExpansion::order3:
      return "3";
    case WlcExpansion::order4:
      return "4";
  }
  return "?";
}

WlcExpansion wlc_expansion_from_string(const std::string& name) {
  if (name == "full") return WlcExpansion::full;
  if (name == "2") return WlcExpansion::order2;
  if (name == "3") return WlcExpansion::order3;
  if (name == "4") return WlcExpansion::order4;
  throw std::invalid_argument("order '" + name + "' is not one of 2, 3, 4, full");
}

WlcDensity make_wlc_density(const WlcParameters& p, WlcExpansion expansion) {
  p.validate();
  WlcDensity w;
  w.x0 = p.lbar_um / p.lmax_um;
  w.prefactor_pN_per_um = units::thermal_energy_pNum(p.temperature_K) * p.lmax_um /
                          (2.0 * units::sqrt3 * p.persistence_um * p.lbar_um * p.lbar_um);
  w.expansion = expansion;
  w.taylor = taylor_at_rest(w.prefactor_pN_per_um, w.x0);
  return w;
}

double max_admissible_z(const WlcDensity& w) {
  return w.expansion == WlcExpansion::full ? 1.0 / (w.x0 * w.x0)
                                           : std::numeric_limits<double>::infinity();
}

double derivative_at_rest(const WlcDensity& w, int n) {
  static constexpr double factorial[5] = {1, 1, 2, 6, 24};
  if (n < 0 || n > 4) throw std::invalid_argument("derivative order must be 0..4");
  return w.taylor[n] * factorial[n];
}

double wlc_tension_pN(const WlcParameters& p, double length_um) {
  const double x = length_um / p.lmax_um;
  const double om = 1.0 - x;
  return units::thermal_energy_pNum(p.temperature_K) / p.persistence_um *
         (0.25 / (om * om) - 0.25 + x);
}

}  // namespace rbc
