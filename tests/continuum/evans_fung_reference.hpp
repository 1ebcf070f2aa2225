// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Closed-form truths of the Evans-Fung rest surface (core/rest_shape.hpp) for the bending tests.
#include <cmath>

#include "core/rest_shape.hpp"
#include "core/units.hpp"

namespace rbc::testing {

// F_CH = 2 int_0^{pi/2} (kappa/2) H^2 2 pi r |gamma'| dt for the upper half profile
// r = R sin t, z = R cos t g(sin^2 t), g(s) = c0 + c1 s + c2 s^2 (smooth at the rim), with
// meridian curvature (r' z'' - z' r'')/|gamma'|^3 and parallel curvature z'/(r |gamma'|).
inline double evans_fung_helfrich_energy(const EvansFungShape& s, double kappa) {
  const int n = 200000;
  const double h = 0.5 * units::pi / n, R = s.radius_um;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double t = (i + 0.5) * h, sn = std::sin(t), cs = std::cos(t);
    const double u = sn * sn, du = 2 * sn * cs, d2u = 2 * (cs * cs - sn * sn);
    const double g = s.c0 + s.c1 * u + s.c2 * u * u, dg = (s.c1 + 2 * s.c2 * u) * du;
    const double d2g = 2 * s.c2 * du * du + (s.c1 + 2 * s.c2 * u) * d2u;
    const double r = R * sn, dr = R * cs, d2r = -R * sn;
    const double z = R * cs * g;
    (void)z;
    const double dz = R * (-sn * g + cs * dg), d2z = R * (-cs * g - 2 * sn * dg + cs * d2g);
    const double speed = std::sqrt(dr * dr + dz * dz);
    const double k1 = (dr * d2z - dz * d2r) / (speed * speed * speed);
    const double k2 = dz / (r * speed);
    const double hh = k1 + k2;
    sum += 0.5 * kappa * hh * hh * 2 * units::pi * r * speed * h;
  }
  return 2 * sum;
}

}  // namespace rbc::testing
