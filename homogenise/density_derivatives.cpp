// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/density_derivatives.hpp"

#include <cmath>
#include <limits>

namespace rbc {

std::array<double, 5> density_derivatives(const WlcDensity& w, double z) {
  std::array<double, 5> d{};
  if (w.expansion != WlcExpansion::full) {
    const int order = w.expansion == WlcExpansion::order2   ? 2
                      : w.expansion == WlcExpansion::order3 ? 3
                                                            : 4;
    const double t = z - 1.0;
    // n-th derivative of sum_j c_j t^j is sum_{j>=n} c_j j!/(j-n)! t^(j-n) (Horner).
    for (int n = 0; n <= 4; ++n) {
      double acc = 0.0;
      for (int j = order; j >= n; --j) {
        double falling = 1.0;
        for (int k = 0; k < n; ++k) falling *= j - k;
        acc = acc * t + w.taylor[j] * falling;
      }
      d[n] = acc;
    }
    return d;
  }
  const double x = w.x0 * std::sqrt(z);
  if (!(z > 0.0) || !(x < 1.0)) {
    d[0] = std::numeric_limits<double>::infinity();
    return d;
  }
  const double r = 1.0 / (1.0 - x);
  const double r2 = r * r, r3 = r2 * r;
  const double p0 = 2 * x * x - x - 1 + r;
  const double p1 = 4 * x - 1 + r2;
  const double p2 = 4 + 2 * r3;
  const double p3 = 6 * r3 * r;
  const double p4 = 24 * r3 * r2;
  const double x1 = x / (2 * z), x2 = -x / (4 * z * z), x3 = 3 * x / (8 * z * z * z),
               x4 = -15 * x / (16 * z * z * z * z);
  const double P = w.prefactor_pN_per_um;
  d[0] = P * p0;
  d[1] = P * p1 * x1;
  d[2] = P * (p2 * x1 * x1 + p1 * x2);
  d[3] = P * (p3 * x1 * x1 * x1 + 3 * p2 * x1 * x2 + p1 * x3);
  d[4] = P * (p4 * x1 * x1 * x1 * x1 + 6 * p3 * x1 * x1 * x2 + 3 * p2 * x2 * x2 + 4 * p2 * x1 * x3 +
              p1 * x4);
  return d;
}

}  // namespace rbc
