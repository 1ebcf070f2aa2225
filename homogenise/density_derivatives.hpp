// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// V(z) and its derivatives up to the fourth, as the orientation-averaged laws need them
// (the smooth-in-b^2 forms of the full WLC average use V''' and V'''').
#include <array>

#include "discrete/wlc.hpp"

namespace rbc {

/// d[n] = d^n V / dz^n at z, n = 0..4, in pN/um (V from discrete/wlc.hpp). For the
/// Taylor expansions these are the polynomial's derivatives; for the full WLC,
/// V(z) = P phi(x), x = x0 sqrt(z), with phi(x) = (3x^2 - 2x^3)/(1 - x)
/// = 2x^2 - x - 1 + 1/(1 - x), so phi^(n) = n! /(1 - x)^(n+1) + polynomial part, composed
/// with x(z) by Faa di Bruno (x' = x/2z, x'' = -x/4z^2, x''' = 3x/8z^3, x'''' = -15x/16z^4).
/// Full law at or beyond z = 1/x0^2 (link at Lmax) or z <= 0: d[0] = +infinity.
std::array<double, 5> density_derivatives(const WlcDensity& w, double z);

}  // namespace rbc
