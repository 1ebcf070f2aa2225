// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Steric face term of Model 1 (MODEL.md section 2, paper eq. (2) second sum; Boey,
// Boal & Discher 1998): keeps the WLC network from collapsing.
#include <Eigen/Core>
#include <cmath>
#include <string>

#include "core/geometry.hpp"
#include "discrete/element_hessian.hpp"
#include "discrete/wlc.hpp"

namespace rbc {

/// Steric exponent q and regularisation eta (dimensionless). Defaults: q = 1, eta = 0.005.
struct StericParameters {
  double q = 1.0;
  double eta = 0.005;
  /// Throws std::invalid_argument (rbc::InvalidParameter) unless q in (0, 10] and eta in
  /// (0, 1] (a regularisation of J^q ~ 1, so small), both finite.
  void validate() const;
};

/// Stress-free steric constant C = 3 (1 + eta)^2 V'(1) / (2 q)  [pN/um] (paper Sec. 3.4):
/// makes the hexagonal network's energy stationary at the rest state.
double steric_constant(const WlcDensity& w, const StericParameters& s);

/// Areal steric density and derivatives in J = A/Abar:
///   s(J) = 2 C / (J^q + eta),  s'(J) = -2 C q J^(q-1) / (J^q + eta)^2,  s''(J)   [pN/um]
struct StericDensity {
  double v = 0, dv = 0, d2v = 0;
};
/// J > 0: a collapsed face is the callers' to refuse (discrete/network.hpp, kCollapsedFaceRatio);
/// at q = 1, J = 0 gives finite values. derivatives = 1 skips d2v (left 0; v and dv carry the same
/// bits). Inline, as wlc.hpp's evaluate: called once per face in the energy loops.
inline StericDensity steric_density(double C, const StericParameters& s, double J,
                                    int derivatives = 2) {
  const bool linear = s.q == 1.0;  // the paper's q; pow(J, 1) is J exactly, and slow
  const double jq = linear ? J : std::pow(J, s.q);
  // One division for the common q = 1 (divisions bound the energy loops' throughput).
  const double inv_den = 1.0 / (jq + s.eta);
  StericDensity r;
  r.v = 2.0 * C * inv_den;
  // d/dJ J^q = q J^(q-1), written with jq/J to stay finite-safe for J > 0; 1 at q = 1.
  const double djq = linear ? 1.0 : s.q * jq / J;
  r.dv = -2.0 * C * djq * (inv_den * inv_den);
  if (derivatives < 2) return r;
  const double d2jq = linear ? 0.0 : s.q * (s.q - 1.0) * jq / (J * J);
  r.d2v = -2.0 * C * (d2jq - 2.0 * djq * djq * inv_den) * (inv_den * inv_den);
  return r;
}

/// The steric face term through its face area, in any coordinates of dimension N (the 9
/// vertex coordinates of a mesh face, the 4 edge-vector components of a planar periodic
/// face): given the area A (um^2), its gradient dA (N) and, for the Hessian, d2A (N x N),
///   E = Abar s(J),  dE = s'(J) dA  [pN],  d2E = s''(J)/Abar dA dA^T + s'(J) d2A  [pN/um],
/// J = A/Abar. The one home of the steric chain rule: every Hessian of the term uses it.
/// d2A_coef maps s'(J) (pN/um) to the whole coefficient of d2A, so that a caller that adds
/// other terms' multiples of the same d2A (a constraint tension, Juelicher's beta_f) forms
/// d2A once: hess = s''(J)/Abar dA dA^T + d2A_coef(s'(J)) d2A (default: s'(J) alone).
struct StericAreaCoefficient {
  double operator()(double ds_pN_per_um) const { return ds_pN_per_um; }
};
template <int N, class AreaCoefficient = StericAreaCoefficient>
double steric_face_terms(double C, const StericParameters& s, double abar_um2, double area_um2,
                         const Eigen::Matrix<double, N, 1>& dA,
                         const Eigen::Matrix<double, N, N>* d2A, Eigen::Matrix<double, N, 1>* grad,
                         Eigen::Matrix<double, N, N>* hess, AreaCoefficient d2A_coef = {}) {
  const StericDensity d = steric_density(C, s, area_um2 / abar_um2);
  if (grad) *grad = d.dv * dA;
  if (hess) *hess = d.d2v / abar_um2 * dA * dA.transpose() + d2A_coef(d.dv) * *d2A;
  return abar_um2 * d.v;
}

/// One face f = (a, b, c) with rest area Abar_f (um^2):
///   E_f = Abar_f s(A_f/Abar_f) = 2 Abar_f C / ((A_f/Abar_f)^q + eta)   [pN um]
///   dE/dx = s'(J) dA/dx                                                  [pN]
/// Columns of grad are dE/da, dE/db, dE/dc (the area gradient of core/geometry.hpp).
inline double steric_face_energy(double C, const StericParameters& s, double abar_um2,
                                 const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                 const Eigen::Vector3d& c, Eigen::Matrix3d* grad = nullptr) {
  Eigen::Matrix3d ga;
  const double area = triangle_area(a, b, c, grad ? &ga : nullptr);
  const StericDensity d = steric_density(C, s, area / abar_um2);
  if (grad) *grad = d.dv * ga;
  return abar_um2 * d.v;
}

/// Hessian (9 x 9, vertex-major a, b, c; pN/um) of steric_face_energy: steric_face_terms
/// with the area derivatives of element_hessian.hpp's triangle_area_hessian.
Matrix9d steric_face_hessian(double C, const StericParameters& s, double abar_um2,
                             const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                             const Eigen::Vector3d& c);

}  // namespace rbc
