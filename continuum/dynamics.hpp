#pragma once
// Overdamped dynamics of the continuum membrane (MODEL.md section 6): backward Euler as a
// minimising movement,
//   x_{n+1} = argmin_x E(x; F) + D(x; x_n),   A(x) = A0, V(x) = V0 exactly,
// E = in-plane Psi + Helfrich - tweezers work (continuum/continuum_model.hpp), D the
// incremental viscous potential of the membrane (continuum/membrane_viscosity.hpp, eta_m on
// the deviatoric and eta_d on the trace of the strain increment), optionally plus a normal
// drag of the surrounding fluids (relax scene). Each step is solved by the same bordered KKT
// Newton method as the static solver (continuum/newton_solver.hpp: CHOLMOD factorisation of
// K = d2(E + D) + lambda d2(A, V) + sigma I, 2 x 2 Schur complement, merit line search; a
// separate copy here because the static solver's energy has no extension point). The
// force tolerance is tolerance_pN_per_s x dt (it shrinks with dt, so it does not hide the
// O(dt) error). Rigid modes: D and E (at F = 0) do not see them; the Levenberg shift
// sigma >= 1e-8 x mean diagonal makes the step the minimum-norm one, with no rigid part.
//
// The fluids' share (stated, not modelled in the in-plane scenes): the cytosol (6 mPa s)
// dissipates ~ eta_cyt R / eta_m ~ 6e-3 Pa s x 4 um / 0.6 pN s/um ~ 4 % of the membrane's
// for in-plane motion; the outer medium (~1 mPa s) ~ 1 %; the beads' Stokes drag
// 6 pi eta a ~ 2e-8 pN s/um is negligible.
#include <Eigen/CholmodSupport>
#include <string>

#include "continuum/continuum_model.hpp"
#include "continuum/membrane_viscosity.hpp"
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
  void validate() const;
};

/// Prepared state (Hessian pattern, symbolic factorisation) for one model.
class ContinuumDynamics {
 public:
  ContinuumDynamics(const ContinuumModel& model, const ContinuumDynamicsOptions& options);
  /// One backward-Euler step at force F (pN) of length dt (s) from state (updated on success).
  StepOutcome step(double force_pN, double dt_s, DynamicsState& state);
  /// E(x) at F without constraint terms, diameters and drifts.
  TrajectorySample measure(double force_pN, const DynamicsState& state) const;

 private:
  const ContinuumModel& model_;
  ContinuumDynamicsOptions options_;
  BlockHessian hessian_;
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>> llt_;
};

}  // namespace rbc
