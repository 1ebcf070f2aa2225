// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/link_dashpot.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "core/validation.hpp"

namespace rbc {

void LinkDashpotParameters::validate() const {
  if (!(gamma_pN_s_per_um > 0) || !std::isfinite(gamma_pN_s_per_um))
    throw std::invalid_argument("link damping gamma must be finite and > 0 pN s/um, got " +
                                format_number(gamma_pN_s_per_um));
  if (!(dt_s > 0) || !std::isfinite(dt_s))
    throw std::invalid_argument("time step must be finite and > 0 s, got " + format_number(dt_s));
}

double link_damping_for_shear_viscosity(double eta_m) {
  constexpr double sqrt3 = 1.73205080756887729353;
  return 4.0 * eta_m / sqrt3;
}

Eigen::VectorXd link_lengths(const Positions& x, const Topology& topo) {
  Eigen::VectorXd l(topo.num_edges());
  for (int e = 0; e < topo.num_edges(); ++e)
    l(e) = (x.col(topo.edges(1, e)) - x.col(topo.edges(0, e))).norm();
  return l;
}

double link_dashpot_energy(const LinkDashpotParameters& p, const Topology& topo,
                           const Eigen::VectorXd& lengths_prev_um, const Positions& x,
                           Positions* grad) {
  const double c = p.gamma_pN_s_per_um / p.dt_s;
  double total = 0.0;
  for (int e = 0; e < topo.num_edges(); ++e) {
    const int a = topo.edges(0, e), b = topo.edges(1, e);
    Eigen::Vector3d g;
    total += link_dashpot_energy(c, lengths_prev_um(e), x.col(a), x.col(b), grad ? &g : nullptr);
    if (grad) {
      grad->col(b) += g;
      grad->col(a) -= g;
    }
  }
  return total;
}

}  // namespace rbc
