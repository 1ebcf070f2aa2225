// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/lattice_density.hpp"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "core/units.hpp"

namespace rbc {

double lattice_density(const WlcDensity& w, double C, const StericParameters& s,
                       const Eigen::Matrix2d& F, double phi, Eigen::Matrix2d* grad) {
  const double J = F.determinant();
  if (!(J > 0.0)) return std::numeric_limits<double>::infinity();
  const Eigen::Matrix2d Cg = F.transpose() * F;
  double psi = 0.0;
  Eigen::Matrix2d g = Eigen::Matrix2d::Zero();
  for (int i = 0; i < 3; ++i) {
    const double angle = phi + i * units::pi / 3.0;
    const Eigen::Vector2d xi(std::cos(angle), std::sin(angle));
    const DensityValue v = evaluate(w, xi.dot(Cg * xi));
    if (!(v.v < std::numeric_limits<double>::infinity())) return v.v;
    psi += v.v;
    if (grad) g += 2.0 * v.dv * (F * xi) * xi.transpose();
  }
  const StericDensity st = steric_density(C, s, J);
  psi += st.v;
  if (grad) {
    Eigen::Matrix2d cof;  // J F^{-T}
    cof << F(1, 1), -F(1, 0), -F(0, 1), F(0, 0);
    *grad = g + st.dv * cof;
  }
  return psi;
}

double average_over_angle(const std::function<double(double)>& f, double period, double rel_tol) {
  constexpr std::size_t kLimit = 1000;
  std::unique_ptr<gsl_integration_workspace, decltype(&gsl_integration_workspace_free)> ws(
      gsl_integration_workspace_alloc(kLimit), &gsl_integration_workspace_free);
  gsl_function gf;
  gf.function = [](double x, void* p) {
    return (*static_cast<const std::function<double(double)>*>(p))(x);
  };
  gf.params = const_cast<std::function<double(double)>*>(&f);
  double result = 0, abserr = 0;
  gsl_error_handler_t* old = gsl_set_error_handler_off();
  const int status = gsl_integration_qag(&gf, 0.0, period, 0.0, rel_tol, kLimit, GSL_INTEG_GAUSS61,
                                         ws.get(), &result, &abserr);
  gsl_set_error_handler(old);
  if (status != GSL_SUCCESS)
    throw std::runtime_error(std::string("orientation average: GSL QAG failed: ") +
                             gsl_strerror(status) + ", error estimate " + std::to_string(abserr));
  return result / period;
}

}  // namespace rbc
