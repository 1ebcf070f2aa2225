// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Finite-difference check of a Hessian against its analytic gradient (STYLE.md 2; MFEM's
// practice): along a seeded random unit direction d, the central difference of the
// gradient, (g(x + h d) - g(x - h d)) / 2h, must approach H d with an error that shrinks at
// second order as h halves, and be small at h ~ cbrt(eps) x length scale.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <limits>
#include <random>

namespace rbc::testing {

using GradientFn = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;

struct HessianCheck {
  double error_h = 0, error_h2 = 0;  ///< |FD - H d| at steps h and h/2 (max norm)
  double error_small = 0;            ///< at h = cbrt(eps) x scale
  double scale = 0;                  ///< |H d| (max norm)
};

/// hd = H d for the direction; returns the errors for steps h = 1e-2 x length and
/// cbrt(eps) x length.
inline HessianCheck check_hessian_direction(
    const GradientFn& grad, const Eigen::VectorXd& x,
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& hess_times, double length,
    unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::VectorXd d(x.size());
  for (Eigen::Index i = 0; i < d.size(); ++i) d(i) = n(rng);
  d /= d.norm();
  const Eigen::VectorXd hd = hess_times(d);
  auto err = [&](double h) {
    const Eigen::VectorXd fd = (grad(x + h * d) - grad(x - h * d)) / (2 * h);
    return (fd - hd).cwiseAbs().maxCoeff();
  };
  HessianCheck c;
  c.error_h = err(1e-2 * length);
  c.error_h2 = err(0.5e-2 * length);
  c.error_small = err(std::cbrt(std::numeric_limits<double>::epsilon()) * length);
  c.scale = hd.cwiseAbs().maxCoeff();
  return c;
}

/// The expectations shared by all Hessian tests.
inline void expect_hessian_ok(const HessianCheck& c, const char* what) {
  const double roundoff = 1e-8 * (1.0 + c.scale);
  if (c.error_h > 10 * roundoff) {
    EXPECT_GT(c.error_h / c.error_h2, 3.0) << what << ": FD error should shrink ~4x as h halves";
  }
  EXPECT_LT(c.error_small, 1e-6 * (1.0 + c.scale)) << what;
}

}  // namespace rbc::testing
