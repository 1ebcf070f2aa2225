// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The one augmented-Lagrangian driver for the area and volume constraints (MODEL.md section 2,
// "Area and volume"; Nocedal & Wright, Numerical Optimization, 2nd ed., Algorithm 17.4 with the
// penalty increase of its Framework 17.3). Used by the discrete stretch (discrete/stretch.cpp)
// and the continuum stretch's L-BFGS path (continuum/continuum_stretch.cpp); the models differ
// only in the inner minimisation they pass in.
//
// Outer iteration k, with multipliers lambda_k and penalty scale s_k (the penalty stiffnesses
// of ConstraintParameters times s_k):
//   1. minimise E(x) + lA (A - A0) + s kA/2 (A - A0)^2 + lV (V - V0) + s kV/2 (V - V0)^2;
//   2. stop if the minimiser failed (not converged and not at its iteration limit), if the
//      caller's budget is spent, or if it converged with both |A - A0|/A0 and |V - V0|/V0 below
//      ConstraintParameters::tolerance;
//   3. lambda_A += s kA (A - A0), lambda_V += s kV (V - V0);
//   4. if the largest relative violation did not fall below required_reduction times the
//      previous one, s *= stiffening_factor (the forces of a small violation had dropped below
//      the minimiser's force tolerance, so the multipliers alone no longer move it).
#include <functional>
#include <string>

#include "core/lbfgs.hpp"
#include "core/progress.hpp"
#include "discrete/constraint_energy.hpp"

namespace rbc {

/// The penalty schedule of the driver (step 4 above); the constants are defined here only.
struct AugmentedLagrangianSchedule {
  /// Required fall of the largest relative violation per multiplier update (dimensionless):
  /// 0.25 is Nocedal & Wright's "decreased sufficiently" at a factor of four.
  double required_reduction = 0.25;
  /// Penalty stiffening when the violation did not fall enough (dimensionless, > 1).
  double stiffening_factor = 10.0;
  /// Throws rbc::InvalidParameter: required_reduction finite in (0, 1], stiffening_factor
  /// finite and >= 1.
  void validate() const;
};

/// Why the driver stopped.
enum class AugmentedLagrangianStop {
  converged,         ///< minimiser converged and both constraints held
  minimiser_failed,  ///< the inner minimisation failed (line search, infeasible start)
  budget_spent,      ///< the caller's budget (iterations, evaluations, wall clock) is spent
  max_updates,       ///< the multiplier updates ran out with the constraints not held
};
std::string to_string(AugmentedLagrangianStop stop);

/// The model-specific part: the inner minimisation and the measurement of the totals.
struct AugmentedLagrangianProblem {
  double area0_um2 = 0, volume0_um3 = 0;  ///< targets A0 (um^2), V0 (um^3)
  /// Penalty stiffnesses kA (pN/um^3), kV (pN/um^5) at scale 1, and the relative tolerance.
  ConstraintParameters constraints;
  /// Minimises at multipliers lambda and penalty scale s from the current point, leaving the
  /// current point at the result.
  std::function<MinimiserResult(const ConstraintMultipliers& lambda, double stiffness_scale)>
      minimise;
  /// Total area (um^2) and enclosed volume (um^3) at the current point.
  std::function<ConstraintState()> measure;
  /// Optional: true when the caller's budget is spent (checked after each minimisation).
  std::function<bool()> budget_spent;
  /// Optional: called after each minimisation with the update index, the minimiser's result
  /// and the relative drifts (A - A0)/A0, (V - V0)/V0 (progress reporting).
  std::function<void(int update, const MinimiserResult& result, double area_drift,
                     double volume_drift)>
      on_update;
  /// Polled once per update (after the stop tests); true stops the run by throwing Cancelled.
  CancelCheck cancel;
};

struct AugmentedLagrangianResult {
  AugmentedLagrangianStop stop = AugmentedLagrangianStop::max_updates;
  MinimiserResult last;     ///< the last inner minimisation (its iterations only)
  int iterations = 0;       ///< inner iterations summed over the updates
  int minimisations = 0;    ///< inner minimisations run
  ConstraintState totals;   ///< A (um^2), V (um^3) at the end
  double area_drift = 0;    ///< (A - A0)/A0 at the end
  double volume_drift = 0;  ///< (V - V0)/V0 at the end
  bool held() const;        ///< both drifts below the tolerance (set by the driver)
  double tolerance = 0;     ///< the tolerance the drifts were compared with
};

/// Runs at most max_updates minimisations (>= 1). lambda and stiffness_scale are the state the
/// next minimisation would use and are updated in place: after a converged run they are the
/// ones of the last minimisation; after the updates ran out, the updated ones.
AugmentedLagrangianResult run_augmented_lagrangian(const AugmentedLagrangianProblem& problem,
                                                   int max_updates,
                                                   const AugmentedLagrangianSchedule& schedule,
                                                   ConstraintMultipliers& lambda,
                                                   double& stiffness_scale);

}  // namespace rbc
