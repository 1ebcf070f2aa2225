// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/hmc_constrained.hpp"

#include <gsl/gsl_rng.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace rbc {

namespace {

/// The constraints at one point: values, J', W = M^-1 J' and G = J M^-1 J' factorised.
struct ConstraintFrame {
  Eigen::VectorXd value;
  Eigen::MatrixXd jt, w;
  Eigen::LLT<Eigen::MatrixXd> g;
  double log_det_g = 0;
  bool ok = false;  ///< G positive definite (the constraints independent at the point)
};

ConstraintFrame frame_at(const HmcConstraints& c, const MassMatrix& mass, const Eigen::VectorXd& x,
                         long long& solves) {
  ConstraintFrame f;
  c.evaluate(x, f.value, f.jt);
  f.w.resize(f.jt.rows(), f.jt.cols());
  for (Eigen::Index a = 0; a < f.jt.cols(); ++a) {
    f.w.col(a) = mass.inverse_times(f.jt.col(a));
    solves += mass.solves_per_inverse();
  }
  Eigen::MatrixXd g = f.jt.transpose() * f.w;
  g = 0.5 * (g + g.transpose()).eval();
  f.g.compute(g);
  f.ok = f.g.info() == Eigen::Success && f.value.allFinite() && f.jt.allFinite();
  if (f.ok) {
    const Eigen::MatrixXd l = f.g.matrixL();
    f.log_det_g = 2.0 * l.diagonal().array().log().sum();
    f.ok = std::isfinite(f.log_det_g);
  }
  return f;
}

/// The Fixman term 1/2 log det G_M at the frame's point; adds its gradient
/// sum_ab (G^-1)_ab d2xi_a W_b to grad.
double add_fixman(const HmcConstraints& c, const Eigen::VectorXd& x, const ConstraintFrame& f,
                  Eigen::VectorXd& grad) {
  const Eigen::Index m = f.jt.cols();
  const Eigen::MatrixXd w_ginv = f.w * f.g.solve(Eigen::MatrixXd::Identity(m, m));
  for (Eigen::Index a = 0; a < m; ++a)
    grad.noalias() += c.hessian_times(x, static_cast<int>(a), w_ginv.col(a));
  return 0.5 * f.log_det_g;
}

bool within_tolerance(const HmcConstraints& c, const Eigen::VectorXd& value) {
  return value.allFinite() && (value.array().abs() <= c.tolerance.array()).all();
}

/// Newton's method for lambda with xi(base - d lambda) = 0, from lambda = start; the root, or
/// nothing when the tolerances are not reached in max_newton iterations.
std::optional<Eigen::VectorXd> solve_position(const HmcConstraints& c, const Eigen::VectorXd& base,
                                              const Eigen::MatrixXd& d,
                                              const Eigen::VectorXd& start) {
  Eigen::VectorXd lambda = start, value;
  Eigen::MatrixXd jt;
  for (int it = 0; it <= c.max_newton; ++it) {
    const Eigen::VectorXd y = base - d * lambda;
    c.evaluate(y, value, jt);
    if (within_tolerance(c, value)) return lambda;
    if (it == c.max_newton || !value.allFinite() || !jt.allFinite()) break;
    // d xi / d lambda = -J(y) d.
    const Eigen::MatrixXd a = jt.transpose() * d;
    Eigen::FullPivLU<Eigen::MatrixXd> lu(a);
    if (!lu.isInvertible()) break;
    lambda.noalias() += lu.solve(value);
  }
  return std::nullopt;
}

void project_momentum(Eigen::VectorXd& p, const ConstraintFrame& f,
                      Eigen::VectorXd* multiplier = nullptr) {
  const Eigen::VectorXd nu = f.g.solve(f.w.transpose() * p);
  p.noalias() -= f.jt * nu;
  if (multiplier) *multiplier = nu;
}

}  // namespace

HmcConstrainedState hmc_constrained_state(const HmcPotential& potential,
                                          const HmcConstraints& constraints, const MassMatrix& mass,
                                          const Eigen::VectorXd& x) {
  long long solves = 0;
  const ConstraintFrame f = frame_at(constraints, mass, x, solves);
  if (!f.ok)
    throw std::runtime_error("constrained HMC: the constraints are dependent at the start");
  if (!within_tolerance(constraints, f.value))
    throw std::runtime_error("constrained HMC: the start is not on the constraint manifold");
  HmcConstrainedState s;
  s.x = x;
  s.gradient.resize(x.size());
  s.potential = potential(s.x, s.gradient);
  if (std::isfinite(s.potential)) {
    s.fixman = add_fixman(constraints, x, f, s.gradient);
    s.potential += s.fixman;
  }
  return s;
}

Eigen::VectorXd hmc_project_onto_constraints(const HmcConstraints& constraints,
                                             const MassMatrix& mass, const Eigen::VectorXd& x) {
  long long solves = 0;
  const ConstraintFrame f = frame_at(constraints, mass, x, solves);
  if (!f.ok) throw std::runtime_error("constrained HMC: the constraints are dependent here");
  const auto lambda =
      solve_position(constraints, x, f.w, Eigen::VectorXd::Zero(constraints.tolerance.size()));
  if (!lambda)
    throw std::runtime_error("constrained HMC: Newton's method did not reach the constraints");
  return x - f.w * *lambda;
}

HmcConstrainedTransition hmc_constrained_transition(const HmcPotential& potential,
                                                    const HmcConstraints& constraints,
                                                    const MassMatrix& mass,
                                                    HmcConstrainedState& state, double step,
                                                    int steps, gsl_rng* rng) {
  HmcConstrainedTransition r;
  HmcTransition& t = r.transition;
  ConstraintFrame f = frame_at(constraints, mass, state.x, t.solves);
  Eigen::VectorXd p = mass.draw(rng);
  t.solves += mass.solves_per_draw();
  bool finite = f.ok;
  if (finite) project_momentum(p, f);
  Eigen::VectorXd v = mass.inverse_times(p);
  t.solves += mass.solves_per_inverse();
  const double h0 = state.potential + 0.5 * p.dot(v);
  finite = finite && std::isfinite(h0);
  Eigen::VectorXd x = state.x, g = state.gradient;
  double u = state.potential, fixman = state.fixman;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(constraints.tolerance.size());
  for (int k = 0; k < steps && finite; ++k) {
    ++t.steps;
    p.noalias() -= 0.5 * step * g;
    v = mass.inverse_times(p);
    t.solves += mass.solves_per_inverse();
    const Eigen::MatrixXd d = step * f.w;
    const auto lambda = solve_position(constraints, x + step * v, d, zero);
    if (!lambda) {
      ++r.failed_solves;
      finite = false;
      break;
    }
    const Eigen::VectorXd x_start = x;
    x.noalias() += step * v - d * *lambda;
    p.noalias() -= f.jt * *lambda;
    f = frame_at(constraints, mass, x, t.solves);
    if (!f.ok) {
      finite = false;
      break;
    }
    u = potential(x, g);
    ++t.evaluations;
    if (!std::isfinite(u) || !g.allFinite()) {
      finite = false;
      break;
    }
    fixman = add_fixman(constraints, x, f, g);
    u += fixman;
    p.noalias() -= 0.5 * step * g;
    Eigen::VectorXd nu;
    project_momentum(p, f, &nu);
    // Reverse check: the reverse step's position solve, from its own start (multiplier 0),
    // lands at x_start + step W(x) (nu - mu); it must find mu = nu.
    const Eigen::MatrixXd d_new = step * f.w;
    const auto mu = solve_position(constraints, x_start + d_new * nu, d_new, zero);
    if (!mu || (d_new * (nu - *mu)).cwiseAbs().maxCoeff() > constraints.reverse_tolerance) {
      ++r.failed_reverse_checks;
      finite = false;
      break;
    }
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
    state.fixman = fixman;
  }
  return r;
}

}  // namespace rbc
