// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/hmc_kernel.hpp"

#include <gsl/gsl_randist.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/validation.hpp"

namespace rbc {

DenseMassMatrix::DenseMassMatrix(const Eigen::MatrixXd& m) {
  if (m.rows() != m.cols() || m.rows() == 0 || !m.allFinite())
    throw std::invalid_argument("mass matrix must be square, non-empty and finite");
  Eigen::LLT<Eigen::MatrixXd> llt(m);
  if (llt.info() != Eigen::Success)
    throw std::invalid_argument("mass matrix must be symmetric positive definite");
  l_ = llt.matrixL();
}

Eigen::VectorXd DenseMassMatrix::draw(gsl_rng* rng) const {
  Eigen::VectorXd z(l_.rows());
  for (Eigen::Index i = 0; i < z.size(); ++i) z(i) = gsl_ran_gaussian_ziggurat(rng, 1.0);
  return l_.triangularView<Eigen::Lower>() * z;
}

Eigen::VectorXd DenseMassMatrix::inverse_times(const Eigen::VectorXd& p) const {
  const Eigen::VectorXd y = l_.triangularView<Eigen::Lower>().solve(p);
  return l_.transpose().triangularView<Eigen::Upper>().solve(y);
}

std::string to_string(HmcMassReference r) {
  return r == HmcMassReference::thermal ? "thermal" : "equilibrium";
}

HmcMassReference hmc_mass_reference_from_string(const std::string& s) {
  if (s == "equilibrium") return HmcMassReference::equilibrium;
  if (s == "thermal") return HmcMassReference::thermal;
  throw std::invalid_argument("HMC mass reference '" + s + "': expected equilibrium or thermal");
}

std::string to_string(HmcAreaVolume a) {
  return a == HmcAreaVolume::exact ? "exact" : "penalty";
}

HmcAreaVolume hmc_area_volume_from_string(const std::string& s) {
  if (s == "penalty") return HmcAreaVolume::penalty;
  if (s == "exact") return HmcAreaVolume::exact;
  throw std::invalid_argument("HMC area and volume '" + s + "': expected penalty or exact");
}

void HmcOptions::validate() const {
  require_finite_in_range("HMC leapfrog step", "", step, 0.0, 4.0);
  require_finite_in_range("HMC trajectory time", "", trajectory_time, 0.0, 100.0);
  require_finite_in_range("HMC step-count jitter", "", jitter, 0.0, 1.0, Ends::closed_open);
  require_integer_in_range("HMC adaptive transitions", adapt_transitions, 0,
                           std::numeric_limits<int>::max());
  require_finite_in_range("HMC target acceptance", "", target_acceptance, 0.0, 1.0,
                          Ends::open_open);
  require_finite_in_range("HMC step adaptation gain", "", adapt_gain, 0.0, 10.0,
                          Ends::closed_closed);
  require_integer_in_range("HMC leapfrog steps cap", max_steps, 1, 1000000);
  require_finite_in_range("HMC mass shift fraction", "", mass_shift_fraction, 1e-8, 1.0,
                          Ends::closed_closed);
}

HmcState hmc_state(const HmcPotential& potential, const Eigen::VectorXd& x) {
  HmcState s;
  s.x = x;
  s.gradient.resize(x.size());
  s.potential = potential(s.x, s.gradient);
  return s;
}

HmcTransition hmc_transition(const HmcPotential& potential, const MassMatrix& mass, HmcState& state,
                             double step, int steps, gsl_rng* rng) {
  HmcTransition t;
  Eigen::VectorXd p = mass.draw(rng);
  t.solves += mass.solves_per_draw();
  Eigen::VectorXd v = mass.inverse_times(p);  // M^-1 p: kinetic energy and first drift
  t.solves += mass.solves_per_inverse();
  const double h0 = state.potential + 0.5 * p.dot(v);
  Eigen::VectorXd x = state.x, g = state.gradient;
  double u = state.potential;
  bool finite = std::isfinite(h0);
  for (int k = 0; k < steps && finite; ++k) {
    p.noalias() -= 0.5 * step * g;
    v = mass.inverse_times(p);
    t.solves += mass.solves_per_inverse();
    x.noalias() += step * v;
    u = potential(x, g);
    ++t.evaluations;
    ++t.steps;
    if (!std::isfinite(u) || !g.allFinite()) {
      finite = false;
      break;
    }
    p.noalias() -= 0.5 * step * g;
  }
  double h1 = std::numeric_limits<double>::infinity();
  if (finite) {
    v = mass.inverse_times(p);
    t.solves += mass.solves_per_inverse();
    h1 = u + 0.5 * p.dot(v);
  }
  hmc_metropolis_test(h0, h1, rng, t);
  if (t.accepted) {
    state.x = std::move(x);
    state.potential = u;
    state.gradient = std::move(g);
  }
  return t;
}

void hmc_metropolis_test(double h0, double h1, gsl_rng* rng, HmcTransition& t) {
  // |dH| beyond which the trajectory counts as divergent: its acceptance exp(-1000) is zero in
  // double precision.
  constexpr double kDivergence = 1000.0;
  const double dh = h1 - h0;
  t.diverged = !std::isfinite(dh) || std::abs(dh) > kDivergence;
  t.energy_error = std::isfinite(dh) ? dh : std::numeric_limits<double>::quiet_NaN();
  t.acceptance_probability = std::isfinite(dh) ? std::min(1.0, std::exp(-dh)) : 0.0;
  const double r = gsl_rng_uniform(rng);
  t.accepted = std::isfinite(dh) && r < t.acceptance_probability;
}

int hmc_step_count(const HmcOptions& o, double step, gsl_rng* rng) {
  const double u = gsl_rng_uniform(rng);
  const double n = o.trajectory_time / step * (1.0 + o.jitter * (2.0 * u - 1.0));
  return static_cast<int>(std::clamp(std::lround(n), 1L, static_cast<long>(o.max_steps)));
}

double hmc_adapted_step(const HmcOptions& o, double step, double acceptance_probability,
                        long long k) {
  // Decaying gain for a fast start, floored so that the step keeps following the acceptance
  // once the chain has left its (often atypically smooth) start for the thermal states.
  const double rate = o.adapt_gain * std::max(1.0 / (1.0 + static_cast<double>(k) / 10.0), 0.1);
  const double next = step * std::exp(rate * (acceptance_probability - o.target_acceptance));
  return std::clamp(next, 1e-4, 4.0);
}

}  // namespace rbc
