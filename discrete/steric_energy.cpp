// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/steric_energy.hpp"

#include <cmath>
#include <stdexcept>

#include "core/validation.hpp"

namespace rbc {

void StericParameters::validate() const {
  require_finite_in_range("steric exponent q", "", q, 0.0, 10.0);
  require_finite_in_range("steric regularisation eta", "", eta, 0.0, 1.0);
}

double steric_constant(const WlcDensity& w, const StericParameters& s) {
  s.validate();
  return 3.0 * (1.0 + s.eta) * (1.0 + s.eta) * derivative_at_rest(w, 1) / (2.0 * s.q);
}

Matrix9d steric_face_hessian(double C, const StericParameters& s, double abar_um2,
                             const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                             const Eigen::Vector3d& c) {
  Vector9d dA;
  Matrix9d d2A, h;
  const double area = triangle_area_hessian(a, b, c, &dA, &d2A);
  steric_face_terms<9>(C, s, abar_um2, area, dA, &d2A, nullptr, &h);
  return h;
}

}  // namespace rbc
