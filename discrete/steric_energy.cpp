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

StericDensity steric_density(double C, const StericParameters& s, double J, int derivatives) {
  const double jq = s.q == 1.0 ? J : std::pow(J, s.q);  // pow(J, 1) is J exactly, and slow
  const double den = jq + s.eta;
  StericDensity r;
  r.v = 2.0 * C / den;
  // d/dJ J^q = q J^(q-1); written with jq/J to stay finite-safe for J > 0.
  const double djq = s.q * jq / J;
  r.dv = -2.0 * C * djq / (den * den);
  if (derivatives < 2) return r;
  const double d2jq = s.q * (s.q - 1.0) * jq / (J * J);
  r.d2v = -2.0 * C * (d2jq / (den * den) - 2.0 * djq * djq / (den * den * den));
  return r;
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
