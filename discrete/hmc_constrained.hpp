// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Hamiltonian Monte Carlo on a constraint manifold: the transition of discrete/hmc_kernel.hpp
// with holonomic constraints xi(x) = 0 (m of them) held exactly by the RATTLE integrator, for
// targets whose penalties are too stiff for a fixed mass matrix (the cell's area and volume:
// docs/validation/monte-carlo.md, "Why the penalties cap the step").
//
// Law. Constrained Hamiltonian dynamics with a fixed mass M, discretised by RATTLE (Andersen
// 1983) with a Metropolis test, samples exp(-U(x)) sigma_M(dx) on Sigma = {xi = 0}, sigma_M the
// surface measure the metric M induces (Lelievre, Rousset and Stoltz, "Hybrid Monte Carlo
// methods for sampling probability measures on submanifolds", Numer. Math. 143, 2019). That law
// depends on M. The law wanted is the limit of infinitely stiff penalties,
//   exp(-U(x)) delta(xi(x)) dx = exp(-U(x)) sigma_M(dx) / sqrt(det G_M(x)) (up to a constant),
//   G_M = J M^-1 J'  (m x m),  J = d xi/dx  (m x d),
// which does not depend on M. So the transition runs on the potential
//   U_F(x) = U(x) + 1/2 log det G_M(x)   (the Fixman term),
//   grad U_F = grad U + sum_ab (G_M^-1)_ab (d2 xi_a) M^-1 J_b'.
// With M = beta K (discrete/hmc_sampler.hpp) log det G_M changes by a constant only.
//
// One transition from x on Sigma:
//   1. p ~ N(0, M), projected onto the cotangent space: p -= J' G^-1 J M^-1 p;
//   2. n RATTLE steps of size h:
//        p -= h/2 grad U_F(x);  x' = x + h M^-1 (p - J(x)' lambda), lambda solving xi(x') = 0 by
//        Newton's method;  p -= J(x)' lambda;  p -= h/2 grad U_F(x');  p -= J(x')' mu, mu making
//        J(x') M^-1 p = 0;
//   3. accept with min(1, exp(H(x, p) - H(x', p'))), H = U_F + p' M^-1 p / 2.
// The position equation can have several roots; the map is reversible only where the reverse
// step finds the root the forward step came from. Each step is therefore checked: the reverse
// position solve from x' must return to x (Zappa, Holmes-Cerfon and Goodman, "Monte Carlo on
// manifolds: sampling densities and integrating functions", CPAM 71, 2018); a step whose
// Newton solve or reverse check fails ends the trajectory, which is rejected (as a divergence).
#include <Eigen/Core>
#include <functional>

#include "discrete/hmc_kernel.hpp"

namespace rbc {

/// The constraints xi(x) = 0 of a target, in any units: each xi_a with the tolerance its
/// Newton solve must reach.
struct HmcConstraints {
  /// Values xi(x) (m) and Jacobian transpose J' = d xi / dx (d x m) at x.
  std::function<void(const Eigen::VectorXd& x, Eigen::VectorXd& value, Eigen::MatrixXd& jacobian_t)>
      evaluate;
  /// d2 xi_a(x) w (d): the Hessian of constraint a times w (for the Fixman term's gradient).
  std::function<Eigen::VectorXd(const Eigen::VectorXd& x, int a, const Eigen::VectorXd& w)>
      hessian_times;
  /// |xi_a| a position solve must reach (units of xi_a), each > 0; its size m is the count.
  Eigen::VectorXd tolerance;
  /// Newton iterations per position solve before the step counts as failed.
  int max_newton = 50;
  /// A reverse position solve must land within this distance of the step's start (units of x).
  double reverse_tolerance = 1e-8;
};

/// The chain's state between transitions: position on Sigma, U_F (with the Fixman term) and its
/// gradient, and the Fixman term alone (so that U = potential - fixman).
struct HmcConstrainedState : HmcState {
  double fixman = 0;  ///< 1/2 log det G_M(x), included in potential
};

/// Evaluates the state at x (x must satisfy the constraints to their tolerances; the caller
/// projects a start, e.g. with hmc_project_onto_constraints).
HmcConstrainedState hmc_constrained_state(const HmcPotential& potential,
                                          const HmcConstraints& constraints, const MassMatrix& mass,
                                          const Eigen::VectorXd& x);

/// x moved along M^-1 J(x)' onto Sigma (Newton's method); std::runtime_error when it does not
/// reach the tolerances.
Eigen::VectorXd hmc_project_onto_constraints(const HmcConstraints& constraints,
                                             const MassMatrix& mass, const Eigen::VectorXd& x);

/// What one constrained transition did: the fields of HmcTransition (a failed position solve or
/// reverse check counts as diverged), and how many steps failed which way.
struct HmcConstrainedTransition {
  HmcTransition transition;
  int failed_solves = 0;          ///< Newton did not reach the tolerances
  int failed_reverse_checks = 0;  ///< the reverse solve did not return to the start
};

/// One transition with `steps` RATTLE steps of size `step` from `state` (updated when
/// accepted). Draws the momentum and the acceptance uniform from rng.
HmcConstrainedTransition hmc_constrained_transition(const HmcPotential& potential,
                                                    const HmcConstraints& constraints,
                                                    const MassMatrix& mass,
                                                    HmcConstrainedState& state, double step,
                                                    int steps, gsl_rng* rng);

}  // namespace rbc
