// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Observed order of the central-difference error of an energy term's derivatives (STYLE.md
// 2; MFEM's practice). Along a seeded random unit direction d, the central differences
//   value -> gradient:   (E(x + h d) - E(x - h d)) / 2h        - g . d
//   gradient -> Hessian: (g(x + h d) - g(x - h d)) / 2h        - H d   (max norm)
// have truncation error c h^2 + O(h^4) when g and H are right, so the observed order
// p = log2(err(h) / err(h/2)) must lie in a band about 2 (a wrong derivative leaves an O(1)
// error: p ~ 0). The steps: h = 1e-2 x length scale, far above the round-off floor (a
// whole-mesh energy is ~1e3 times its directional derivative, so eps |E| / h must stay
// well below c h^2) and in the asymptotic range (the O(h^4) correction is ~1e-4
// relative); and h = cbrt(eps) x length scale, the step that balances truncation and
// round-off, where the error must be within a factor of the estimate of both.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>

namespace rbc::testing {

/// Round-off of a central difference of a sum of n ~ 10^3 terms: the sum's rounding grows
/// like sqrt(n) eps |E| (random-walk model), and the difference doubles it: ~100 eps |E|.
constexpr double kRoundoffFactor = 100.0;

struct FdOrder {
  double err_h = 0, err_h2 = 0;  ///< errors at h = 1e-2 x length and h/2
  double err_small = 0;          ///< error at h = cbrt(eps) x length
  double scale = 0;              ///< size of the exact directional derivative (|g.d| or |H d|)
  double h = 0, h_small = 0;     ///< the steps (um)
  double roundoff = 0;           ///< eps x (size of what is differenced) / h_small
  double order() const { return std::log2(err_h / err_h2); }
  /// What the error at h_small may be: the h^2 truncation scaled down from h, plus round-off.
  double small_step_bound() const { return err_h * (h_small / h) * (h_small / h) + roundoff; }
};

inline Eigen::VectorXd random_direction(Eigen::Index n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd d(n);
  for (Eigen::Index i = 0; i < n; ++i) d(i) = normal(rng);
  return d / d.norm();
}

/// The errors of one central difference err(h) at the two asymptotic steps and at the
/// cbrt(eps) step; scale is the exact derivative's size, size that of what is differenced.
template <class Error>
FdOrder measure_order(const Error& err, double length, double scale, double size) {
  FdOrder r;
  r.h = 1e-2 * length;
  r.err_h = err(r.h);
  r.err_h2 = err(0.5 * r.h);
  r.h_small = std::cbrt(std::numeric_limits<double>::epsilon()) * length;
  r.err_small = err(r.h_small);
  r.scale = scale;
  r.roundoff = kRoundoffFactor * std::numeric_limits<double>::epsilon() * size / r.h_small;
  return r;
}

/// Value -> gradient along a random direction (seed); length scale in um.
inline FdOrder gradient_order(const std::function<double(const Eigen::VectorXd&)>& energy,
                              const Eigen::VectorXd& x, const Eigen::VectorXd& grad, double length,
                              unsigned seed) {
  const Eigen::VectorXd d = random_direction(x.size(), seed);
  const double exact = grad.dot(d);
  const auto err = [&](double h) {
    return std::abs((energy(x + h * d) - energy(x - h * d)) / (2 * h) - exact);
  };
  return measure_order(err, length, std::abs(exact), std::abs(energy(x)));
}

/// Gradient -> Hessian along a random direction; hess_times(d) = H d.
inline FdOrder hessian_order(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& grad, const Eigen::VectorXd& x,
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& hess_times, double length,
    unsigned seed) {
  const Eigen::VectorXd d = random_direction(x.size(), seed);
  const Eigen::VectorXd hd = hess_times(d);
  const auto err = [&](double h) {
    return ((grad(x + h * d) - grad(x - h * d)) / (2 * h) - hd).cwiseAbs().maxCoeff();
  };
  return measure_order(err, length, hd.cwiseAbs().maxCoeff(), grad(x).cwiseAbs().maxCoeff());
}

/// The observed order lies in [1.8, 2.2], the h = 1e-2 error is small against the
/// derivative itself (< 1e-3 relative: a derivative right up to a small term still fails),
/// and the cbrt(eps) step's error is within 10x of its truncation-plus-round-off estimate.
inline void expect_second_order(const FdOrder& r, const std::string& what) {
  EXPECT_GE(r.order(), 1.8) << what << ": err(h) = " << r.err_h << ", err(h/2) = " << r.err_h2
                            << ", scale " << r.scale << ", round-off " << r.roundoff;
  EXPECT_LE(r.order(), 2.2) << what << ": err(h) = " << r.err_h << ", err(h/2) = " << r.err_h2;
  EXPECT_LT(r.err_h, 1e-3 * r.scale) << what;
  EXPECT_LT(r.err_small, 10 * r.small_step_bound())
      << what << " at h = cbrt(eps) x length: " << r.err_small << ", round-off " << r.roundoff;
}

}  // namespace rbc::testing
