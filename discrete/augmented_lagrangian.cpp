// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/augmented_lagrangian.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/validation.hpp"

namespace rbc {

void AugmentedLagrangianSchedule::validate() const {
  require_finite_in_range("augmented-Lagrangian required violation reduction", "",
                          required_reduction, 0.0, 1.0, Ends::open_closed);
  require_finite_in_range("augmented-Lagrangian penalty stiffening factor", "", stiffening_factor,
                          1.0, kUnbounded, Ends::closed_open);
}

std::string to_string(AugmentedLagrangianStop stop) {
  switch (stop) {
    case AugmentedLagrangianStop::converged:
      return "converged";
    case AugmentedLagrangianStop::minimiser_failed:
      return "minimiser failed";
    case AugmentedLagrangianStop::budget_spent:
      return "budget spent";
    case AugmentedLagrangianStop::max_updates:
      return "constraints not held after multiplier updates";
  }
  return "unknown";
}

bool AugmentedLagrangianResult::held() const {
  return std::abs(area_drift) < tolerance && std::abs(volume_drift) < tolerance;
}

AugmentedLagrangianResult run_augmented_lagrangian(const AugmentedLagrangianProblem& problem,
                                                   int max_updates,
                                                   const AugmentedLagrangianSchedule& schedule,
                                                   ConstraintMultipliers& lambda,
                                                   double& stiffness_scale) {
  require_integer_in_range("augmented-Lagrangian updates", max_updates, 1, 10000);
  schedule.validate();
  const ConstraintParameters& k = problem.constraints;
  AugmentedLagrangianResult res;
  res.tolerance = k.tolerance;
  double previous_violation = std::numeric_limits<double>::infinity();
  for (int update = 0; update < max_updates; ++update) {
    const MinimiserResult r = problem.minimise(lambda, stiffness_scale);
    res.last = r;
    res.iterations += r.iterations;
    ++res.minimisations;
    res.totals = problem.measure();
    const double da = res.totals.area_um2 - problem.area0_um2;
    const double dv = res.totals.volume_um3 - problem.volume0_um3;
    res.area_drift = da / problem.area0_um2;
    res.volume_drift = dv / problem.volume0_um3;
    if (problem.on_update) problem.on_update(update, r, res.area_drift, res.volume_drift);
    if (!r.converged() && r.status != MinimiserStatus::max_iterations) {
      res.stop = AugmentedLagrangianStop::minimiser_failed;
      return res;
    }
    if (problem.budget_spent && problem.budget_spent()) {
      res.stop = r.converged() && res.held() ? AugmentedLagrangianStop::converged
                                             : AugmentedLagrangianStop::budget_spent;
      return res;
    }
    throw_if_cancelled(problem.cancel);
    if (r.converged() && res.held()) {
      res.stop = AugmentedLagrangianStop::converged;
      return res;
    }
    lambda.area_pN_per_um += stiffness_scale * k.area_stiffness_pN_per_um3 * da;
    lambda.volume_pN_per_um2 += stiffness_scale * k.volume_stiffness_pN_per_um5 * dv;
    const double violation = std::max(std::abs(res.area_drift), std::abs(res.volume_drift));
    if (violation > schedule.required_reduction * previous_violation)
      stiffness_scale *= schedule.stiffening_factor;
    previous_violation = violation;
  }
  res.stop = AugmentedLagrangianStop::max_updates;
  return res;
}

}  // namespace rbc
