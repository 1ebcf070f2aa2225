// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Worm-like-chain spectrin links through the universal energy density V(z)
// (MODEL.md section 2; Hartmann 2008 eq. (5); Marko & Siggia 1995; Li et al. 2005 Table 1).
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "core/defaults.hpp"
#include "core/units.hpp"

namespace rbc {

/// Spectrin-level WLC parameters, internal units (um, K). Defaults: Li et al. 2005,
/// Table 1 of the paper: Lbar = 75 nm, Lmax = 237.75 nm, p = 7.5 nm, T = 300 K.
struct WlcParameters {
  /// rest (equilibrium) link length at the spectrin level
  double lbar_um = units::nm_to_um(defaults::kLbar_nm);
  double lmax_um = units::nm_to_um(defaults::kLmax_nm);                ///< contour (maximum) length
  double persistence_um = units::nm_to_um(defaults::kPersistence_nm);  ///< persistence length p
  double temperature_K = defaults::kWlcTemperature_K;
  /// Throws std::invalid_argument (rbc::InvalidParameter) naming the quantity, the value and the
  /// documented range, with lengths in nm: Lbar in (0, kMaxWlcLength_nm], Lmax in
  /// (Lbar, kMaxWlcLength_nm], p in (0, kMaxWlcLength_nm], T in (0, kMaxTemperature_K]; all finite.
  void validate() const;
};

/// Largest spectrin-level length (Lbar, Lmax, p) accepted, nm: 10 um, beyond any spectrin
/// tetramer (contour length ~200 nm, Li et al. 2005) yet far from overflow.
inline constexpr double kMaxWlcLength_nm = 1e4;
/// Largest temperature accepted (K): well above where the membrane exists (~330 K), below
/// where kB T would swamp every energy scale of the model.
inline constexpr double kMaxTemperature_K = 1000.0;

/// Which form of V: the full WLC, or its Taylor expansion about z = 1 of order 2, 3 or 4.
enum class WlcExpansion { full, order2, order3, order4 };
std::string to_string(WlcExpansion e);
/// Parses "full", "2", "3", "4" (throws std::invalid_argument otherwise).
WlcExpansion wlc_expansion_from_string(const std::string& name);

/// The density V(z), z = L^2/Lbar^2 (pN/um), defined by
///   (sqrt3/2) Lbar^2 V(L^2/Lbar^2) = U_WLC(L) = kB T Lmax/(4p) (3x^2 - 2x^3)/(1 - x),  x = L/Lmax,
/// i.e. V(z) = prefactor * phi(x0 sqrt z), phi(x) = (3x^2 - 2x^3)/(1 - x), x0 = Lbar/Lmax,
/// prefactor = kB T Lmax / (2 sqrt3 p Lbar^2). Because V is fixed, a coarse link of rest
/// length Lbar_e stores (sqrt3/2) Lbar_e^2 V(L^2/Lbar_e^2): same x0, same p*Lbar.
struct WlcDensity {
  double prefactor_pN_per_um = 0.0;
  double x0 = 0.0;  ///< Lbar/Lmax (0.31546 for the defaults)
  WlcExpansion expansion = WlcExpansion::full;
  /// Taylor coefficients V^(j)(1)/j!, j = 0..4 (pN/um), exact (computed by jet arithmetic).
  std::array<double, 5> taylor{};
};

WlcDensity make_wlc_density(const WlcParameters& params,
                            WlcExpansion expansion = WlcExpansion::full);

/// V, dV/dz and d2V/dz2 at z (pN/um).
struct DensityValue {
  double v = 0, dv = 0, d2v = 0;
};

namespace detail {
/// V and its z-derivatives from the Taylor coefficients, at d = z - 1.
inline DensityValue evaluate_expansion(const WlcDensity& w, double d, int derivatives) {
  DensityValue r;
  const int order = w.expansion == WlcExpansion::order2   ? 2
                    : w.expansion == WlcExpansion::order3 ? 3
                                                          : 4;
  for (int j = order; j >= 0; --j) r.v = r.v * d + w.taylor[j];
  for (int j = order; j >= 1; --j) r.dv = r.dv * d + j * w.taylor[j];
  if (derivatives > 1)
    for (int j = order; j >= 2; --j) r.d2v = r.d2v * d + j * (j - 1) * w.taylor[j];
  return r;
}
/// The full law at x = x0 sqrt(z) = L/Lmax: v = +infinity (dv = d2v = 0) unless 0 < x < 1.
/// Without branches (an infeasible x is replaced by 1/2 before any arithmetic, so no operation
/// sees a NaN or divides by zero, and the infinity is selected at the end), so loops over links
/// vectorise; a feasible x gives the bits of the branching form.
inline DensityValue evaluate_full(const WlcDensity& w, double x_in, int derivatives) {
  const bool feasible = x_in < 1.0 && x_in > 0.0;
  const double x = feasible ? x_in : 0.5;
  DensityValue r;
  // One division: q = 1/((1 - x) x) gives 1/(1 - x) = q x and 1/x = q (1 - x) (divisions bound
  // the energy loops' throughput; the result moves by a few ulps).
  const double om = 1.0 - x;
  const double q = 1.0 / (om * x);
  const double inv_om = q * x, inv_x = q * om;
  const double phi = (3 * x * x - 2 * x * x * x) * inv_om;
  const double dphi = (6 * x - 9 * x * x + 4 * x * x * x) * (inv_om * inv_om);
  const double dx = 0.5 * w.x0 * w.x0 * inv_x;  // dx/dz = x0^2/(2x)
  r.v = feasible ? w.prefactor_pN_per_um * phi : std::numeric_limits<double>::infinity();
  r.dv = feasible ? w.prefactor_pN_per_um * dphi * dx : 0.0;
  if (derivatives < 2) return r;
  const double d2phi = (6 - 12 * x + 12 * x * x - 4 * x * x * x) * (inv_om * inv_om * inv_om);
  const double d2x = -0.25 * w.x0 * w.x0 * w.x0 * w.x0 * (inv_x * inv_x * inv_x);  // d2x/dz2
  r.d2v = feasible ? w.prefactor_pN_per_um * (d2phi * dx * dx + dphi * d2x) : 0.0;
  return r;
}
}  // namespace detail

/// Evaluates V(z) and its first two derivatives. For the full law, z at or beyond
/// 1/x0^2 (link at Lmax) returns v = +infinity: callers treat it as infeasible.
/// derivatives = 1 skips d2v (left 0; v and dv carry the same bits). Inline: the energy loops
/// call it once per link, and a call per link cost 7 % of a discrete energy + gradient.
inline DensityValue evaluate(const WlcDensity& w, double z, int derivatives = 2) {
  if (w.expansion != WlcExpansion::full) return detail::evaluate_expansion(w, z - 1.0, derivatives);
  return detail::evaluate_full(w, w.x0 * std::sqrt(z), derivatives);
}

/// evaluate() at z = stretch^2, stretch = L/Lbar (> 0), for callers that hold the stretch: the
/// full law needs no square root then.
inline DensityValue evaluate_stretch(const WlcDensity& w, double stretch, int derivatives = 2) {
  if (w.expansion != WlcExpansion::full)
    return detail::evaluate_expansion(w, stretch * stretch - 1.0, derivatives);
  return detail::evaluate_full(w, w.x0 * stretch, derivatives);
}

/// Largest admissible z: 1/x0^2 for the full law (link at Lmax), +infinity for expansions.
double max_admissible_z(const WlcDensity& w);

/// n-th derivative of V at z = 1, n = 0..4 (pN/um): the Taylor data the moduli use.
double derivative_at_rest(const WlcDensity& w, int n);

/// WLC tension f(L) = dU_WLC/dL = kB T/p (1/(4 (1-x)^2) - 1/4 + x) in pN at the spectrin level.
double wlc_tension_pN(const WlcParameters& params, double length_um);

}  // namespace rbc
