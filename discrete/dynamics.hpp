// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Overdamped dynamics of the discrete network (MODEL.md section 6): gradient flow of the
// free energy E (discrete/network.hpp) under the link dashpots' Rayleigh potential
// (discrete/link_dashpot.hpp), by backward Euler as a minimising movement,
//   x_{n+1} = argmin_x E(x; F) + gamma/(2 dt) sum_e (L_e(x) - L_e(x_n))^2,
// with the total area and volume held by the same augmented Lagrangian and L-BFGS
// (core/lbfgs.hpp) as the static stretch (discrete/stretch.cpp). The multipliers are carried
// from step to step. The step's force tolerance is tolerance_pN_per_s x dt, so the solver
// error per unit time stays below the scheme's O(dt) error as dt shrinks.
// Rigid modes: the dashpots see link lengths only, so the step's objective does not see a
// rigid translation, nor a rigid rotation at F = 0, nor a rotation about the stretch axis x
// at F > 0 (the beads pull along x). Each converged step therefore removes the rigid motion
// from x_n to x_{n+1} that the objective does not see (remove_unseen_rigid_motion): this
// changes neither the objective nor the residual, and fixes the otherwise free rigid part of
// the minimiser (L-BFGS, whose updates are combinations of torque-free gradients, would let
// a rotation drift in at second order in the step).
// The fluids are not modelled: the cytosol's share of the in-plane dissipation is ~3-4 % of
// the membrane's (MODEL.md section 6: eta_cyt R / eta_m ~ 6e-3 Pa s x 3.9 um / 0.7 pN s/um),
// the outer medium's ~0.6 %; a bead of radius 2.06 um (Mills et al. 2004) in water has
// Stokes drag 6 pi eta a ~ 0.039 pN s/um (1 Pa s = 1 pN s/um^2), which, at half the D_A rate
// for each of the two beads, is ~1 % of the cell's axial drag k_eff eta_m/mu ~ 1.7 pN s/um
// (rbc dynamics reports these per scene).
#include <functional>
#include <string>
#include <vector>

#include "core/progress.hpp"
#include "discrete/link_dashpot.hpp"
#include "discrete/network.hpp"

namespace rbc {

/// State advanced by a step: positions and the constraint multipliers, and the previous
/// positions and step for the two-step scheme (TimeScheme::bdf2; ignored by backward Euler).
struct DynamicsState {
  Positions x;  ///< 3 x N (um)
  ConstraintMultipliers lambda;
  Positions previous_x{};      ///< x_{n-1} (um); empty before the first step
  double previous_dt_s = 0.0;  ///< t_n - t_{n-1} (s); 0 before the first step
};

/// Outcome of one (sub)step.
struct StepOutcome {
  bool converged = false;
  int iterations = 0;
  double residual_pN = 0.0;  ///< largest net vertex force of the step's objective
  std::string status;
};

/// One implicit step of length dt (s) from state (updated only on success).
using StepFunction = std::function<StepOutcome(double dt_s, DynamicsState& state)>;

/// Sample of a trajectory.
struct TrajectorySample {
  double t_s = 0.0;
  double axial_um = 0.0, transverse_um = 0.0;  ///< D_A, D_T
  double energy_pNum = 0.0;                    ///< E(x) without constraint terms
  double area_drift = 0.0, volume_drift = 0.0;
  int iterations = 0;  ///< solver iterations of the step(s) since the last sample
};

struct TrajectoryOptions {
  double duration_s = 1.0;  ///< > 0
  double dt_s = 1e-3;       ///< > 0, <= duration
  int max_halvings = 4;     ///< a failing step is retried as two half steps, this deep
  int sample_every = 1;     ///< steps between samples (and snapshots)
  void validate() const;    ///< throws std::invalid_argument naming the value
};

struct TrajectoryResult {
  std::vector<TrajectorySample> samples;
  std::vector<Positions> snapshots;  ///< positions at the samples
  bool converged = true;
  int halved_steps = 0;  ///< steps that needed halving
  double residual_pN = 0.0;
  std::string status = "converged";
  double wall_s = 0.0;
};

/// Measures a state (energy at force F, diameters, drifts).
using Measure = std::function<TrajectorySample(const DynamicsState& state)>;

/// Runs steps of dt to the duration (the last one shortened to land on it), halving a
/// failing step up to max_halvings times (reported on progress); stops at the first step
/// that fails at the finest dt.
TrajectoryResult run_trajectory(const StepFunction& step, const Measure& measure,
                                DynamicsState state, const TrajectoryOptions& options,
                                const ProgressSink& progress = {});

/// Time discretisation of the discrete step.
enum class TimeScheme {
  /// x_{n+1} = argmin E + gamma/(2 dt) sum (L - L^n)^2: first order, E never increases.
  backward_euler,
  /// Variable-step BDF2 on the link-length rates: with w = dt_n/dt_{n-1} and
  /// a = (1 + 2w)/(1 + w), dL/dt ~ a (L - L*)/dt, L* = [(1 + w) L^n - w^2/(1 + w) L^{n-1}]/a,
  /// so the step minimises E + a gamma/(2 dt) sum (L - L*)^2 (the same dashpot term): second
  /// order, A-stable; the first step (no x_{n-1}) is backward Euler. Not energy-monotone.
  bdf2,
};

struct DiscreteDynamicsOptions {
  TimeScheme scheme = TimeScheme::backward_euler;
  double shear_viscosity_pN_s_per_um = 0.7;  ///< eta_m; gamma = 4 eta_m/sqrt3 (> 0)
  double tolerance_pN_per_s = 1.0;           ///< step force tolerance = this x dt (> 0)
  int max_iterations = 20000;                ///< L-BFGS iterations per multiplier update
  int max_outer_iterations = 30;             ///< augmented-Lagrangian updates per step
  void validate() const;
};

/// Moves x rigidly so that it has no rigid motion relative to reference (3 x N, um) among
/// the modes the step's objective does not see: the centroid is put on the reference's, and
/// x is rotated about it by the least-squares (Kabsch) rotation onto the reference, a full
/// 3-d rotation when full_rotation (F = 0) and a rotation about the x axis otherwise
/// (F > 0). Afterwards sum_i (x_i - c) x (r_i - c) = 0 (all three components, or the x
/// component only).
void remove_unseen_rigid_motion(Positions& x, const Positions& reference, bool full_rotation);

/// One backward-Euler step of the network at bead force F (pN) from state.x. F must be finite
/// and in [0, kMaxDiscreteForce_pN] (validate_discrete_force: rbc::InvalidParameter).
StepOutcome discrete_dynamics_step(const Network& net, double force_pN, double dt_s,
                                   DynamicsState& state, const DiscreteDynamicsOptions& options);

/// Hochmuth, Worthy & Evans (1979) recovery measure m = (lambda - lambda_inf)/(lambda +
/// lambda_inf), lambda = D_A/D_T, modelled as m(0) exp(-t/t_c).
struct RecoveryFit {
  double recovery_time_s = 0.0;      ///< t_c
  double recovery_time_err_s = 0.0;  ///< standard error of t_c from the fit residuals
  double lambda_inf = 1.0;           ///< the limit used (given or fitted)
  double m0 = 0.0;                   ///< fitted m(0)
  double window_start_s = 0.0, window_end_s = 0.0;
  int points = 0;
  bool valid = false;  ///< false if fewer than 3 points lie in the window
};

/// Least-squares fit of ln m = ln m0 - t/t_c over the window from t = 0 to the last sample
/// before m first falls below low_fraction x m(0) (the stated window: it excludes the noisy
/// tail where m ~ 0). t (s) and lambda (dimensionless) of equal length.
RecoveryFit fit_recovery(const std::vector<double>& t_s, const std::vector<double>& lambda,
                         double lambda_inf, double low_fraction = 0.1);

/// As above with lambda_inf unknown (an experiment's curve): lambda_inf is chosen in
/// [1, min lambda) to minimise the squared error of the fitted lambda(t) over all points.
RecoveryFit fit_recovery_free_limit(const std::vector<double>& t_s,
                                    const std::vector<double>& lambda);

/// E(x) at force F without constraint terms (pN um), diameters and drifts.
TrajectorySample measure_discrete(const Network& net, double force_pN, const DynamicsState& s);

}  // namespace rbc
