// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Overdamped dynamics of the continuum membrane (MODEL.md section 6): backward Euler as a
// minimising movement,
//   x_{n+1} = argmin_x E(x; F) + D(x; x_n),   A(x) = A0, V(x) = V0 exactly,
// E = in-plane Psi + Helfrich - tweezers work (continuum/continuum_model.hpp), D the
// incremental viscous potential of the membrane (continuum/membrane_viscosity.hpp, eta_m on
// the deviatoric and eta_d on the trace of the strain increment), optionally plus a normal
// drag of the surrounding fluids (relax scene). Each step is solved by the project's one
// bordered KKT Newton method (core/shifted_newton.hpp, as the static solver: sparse Cholesky of
// K = d2(E + D) + lambda d2(A, V) + sigma I, 2 x 2 Schur complement, merit line search). For
// small dt the viscous Hessian (~ 1/dt) dominates K, so K barely changes from step to step: the
// factorisation is kept across iterations and time steps (chord steps) while each step still
// contracts the residual, and refreshed when it does not (or when dt changes). The force
// tolerance is tolerance_pN_per_s x dt (it shrinks with dt, so it does not hide the O(dt)
// error), but not below min_tolerance_pN, the round-off floor of the net vertex forces. Rigid
// modes: without the normal drag, D and E do not see the translations and the rotation about
// the pulling axis (at F = 0 none of the rotations): they are projected out of every Newton
// step (Euclidean projection at the current x). The 1e-8 shift alone would leave them to the
// factorisation, and a chord step on an older K turns the residual's tiny component along them
// into a spurious rotation of the cell (measured: D_A off by 1e-2 um after 3 steps).
//
// The fluids' share (stated, not modelled in the in-plane scenes): the cytosol (6 mPa s)
// dissipates ~ eta_cyt R / eta_m ~ 6e-3 Pa s x 4 um / 0.6 pN s/um ~ 4 % of the membrane's
// for in-plane motion; the outer medium (~1 mPa s) ~ 1 %; the beads' Stokes drag
// 6 pi eta a ~ 2e-8 pN s/um is negligible.
#include <string>

#include "continuum/block_hessian.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/membrane_viscosity.hpp"
#include "core/shifted_newton.hpp"
#include "discrete/dynamics.hpp"

namespace rbc {

struct ContinuumDynamicsOptions {
  double shear_viscosity_pN_s_per_um = 0.7;  ///< eta_m (> 0)
  /// eta_d / eta_m (>= 0); 2 = the hexagonal network's value (homogenise/dissipation.hpp)
  double dilatational_ratio = 2.0;
  /// Normal drag of the fluids per area, R_n = zeta/2 sum_i a_i (v_i . n_i)^2 (pN s/um^3),
  /// 0 = off (in-plane scenes). Relax scene estimate: zeta ~ 2 (eta_in + eta_out) q with
  /// q ~ 2 pi / (cell circumference ~ 25 um) -> 2 x 7e-3 Pa s x 0.25/um ~ 3.5e-3 pN s/um^3
  /// (qualitative: the Stokes flow of a mode of wavenumber q over a flat membrane).
  double normal_drag_pN_s_per_um3 = 0.0;
  double tolerance_pN_per_s = 1.0;      ///< step force tolerance = this x dt (> 0)
  double constraint_tolerance = 1e-10;  ///< |A - A0|/A0, |V - V0|/V0 at convergence
  int max_iterations = 50;              ///< Newton iterations per step
  double max_step_um = 0.5;             ///< largest vertex displacement of one Newton update
  /// Floor of the step force tolerance (pN): the net vertex forces' round-off level at the
  /// 1 % resolution is ~1e-9 pN, so tolerance_pN_per_s x dt below this only burns iterations.
  double min_tolerance_pN = 1e-7;
  /// Keep the Cholesky factorisation across Newton iterations and time steps (chord steps,
  /// refreshed when a full step contracts the residual by less than reuse_contraction, or
  /// when dt changes). false = plain Newton with a fresh factorisation per iteration.
  bool reuse_factorisation = true;
  /// Start each step's Newton from the extrapolation of the previous step (when it
  /// continues that step), else from x_n.
  bool extrapolate_start = true;
  /// Chord iterations in a row before a fresh factorisation (bounded well below
  /// max_iterations so a slowly contracting chord never exhausts a step's budget).
  int max_factor_reuse = 10;
  /// A chord step is followed by another while the full step cut the residual by this
  /// factor, in (0, 1). Measured at the 1 % resolution, dt = 1 ms (rbc bench sweep
  /// --benchmark_filter=recovery): 0.25 -> 144 factorisations in 1,000 steps, 0.7 -> 107; a
  /// chord iteration (one evaluation and solve) costs ~1/10 of a fresh Hessian and
  /// factorisation.
  double reuse_contraction = 0.7;
  void validate() const;
};

/// Prepared state (Hessian pattern, symbolic factorisation) for one model.
class ContinuumDynamics {
 public:
  ContinuumDynamics(const ContinuumModel& model, const ContinuumDynamicsOptions& options);
  /// One backward-Euler step at force F (pN) of length dt (s) from state (updated on success).
  /// F must be finite and in [0, kMaxContinuumForce_pN] (validate_continuum_force).
  StepOutcome step(double force_pN, double dt_s, DynamicsState& state);
  /// E(x) at F without constraint terms, diameters and drifts.
  TrajectorySample measure(double force_pN, const DynamicsState& state) const;

 private:
  const ContinuumModel& model_;
  ContinuumDynamicsOptions options_;
  BlockHessian hessian_;
  ShiftedNewton newton_;
  double factor_dt_s_ = 0.0;  ///< dt of the kept factorisation
  double factor_force_pN_ = 0.0;
  /// The last accepted step (x_{n+1} and x_{n+1} - x_n, its dt): when the next step starts
  /// from that x_{n+1}, Newton starts from the linear extrapolation x_{n+1} + dt'/dt (x_{n+1} -
  /// x_n), which is O(dt^2) from the solution instead of O(dt) (only the start changes, not
  /// the solution the step converges to).
  Positions last_x_, last_step_;
  double last_dt_s_ = 0.0;

 public:
  /// Counters over the object's lifetime (for benchmarks and the note).
  struct Counters {
    long steps = 0, iterations = 0, factorisations = 0, chord_steps = 0;
  };
  const Counters& counters() const { return counters_; }

 private:
  Counters counters_;
};

}  // namespace rbc
