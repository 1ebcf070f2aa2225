// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Spectrin link term of Model 1 (MODEL.md section 2, paper eq. (2) first sum).
#include <Eigen/Core>
#include <limits>

#include "discrete/wlc.hpp"

namespace rbc {

/// One link e = (a, b) with rest length Lbar_e (um):
///   E_e = (sqrt3/2) Lbar_e^2 V(z),  z = |b - a|^2 / Lbar_e^2            [pN um]
///   dE/db = sqrt3 V'(z) (b - a) = -dE/da                                 [pN]
///   d2E/db2 = sqrt3 (V'(z) I + 2 V''(z) (b - a)(b - a)^T / Lbar_e^2)     [pN/um]
/// Returns +infinity (gradient untouched) when the link is at or past its Lmax_e = Lbar_e/x0.
inline double link_energy(const WlcDensity& w, double lbar_um, const Eigen::Vector3d& a,
                          const Eigen::Vector3d& b, Eigen::Vector3d* grad_b = nullptr,
                          Eigen::Matrix3d* hess_bb = nullptr) {
  constexpr double sqrt3 = 1.73205080756887729353;
  const Eigen::Vector3d d = b - a;
  const double lbar2 = lbar_um * lbar_um;
  const double z = d.squaredNorm() / lbar2;
  const DensityValue v = evaluate(w, z);
  if (!(v.v < std::numeric_limits<double>::infinity())) return v.v;
  if (grad_b) *grad_b = sqrt3 * v.dv * d;
  if (hess_bb)
    *hess_bb =
        sqrt3 * (v.dv * Eigen::Matrix3d::Identity() + 2.0 * v.d2v / lbar2 * d * d.transpose());
  return 0.5 * sqrt3 * lbar2 * v.v;
}

}  // namespace rbc
