// SPDX-License-Identifier: GPL-3.0-or-later
// The augmented-Lagrangian driver on a problem with a closed-form inner minimiser:
// E(a, v) = 1/2 (a - c_a)^2 + 1/2 (v - c_v)^2 with the "area" a and the "volume" v held at
// a0, v0. The augmented Lagrangian at multipliers (lA, lV) and penalty s k is minimised by
// a = (c_a + s kA a0 - lA) / (1 + s kA) (same for v), and the exact multipliers are
// lA* = c_a - a0, lV* = c_v - v0 (stationarity of E + lA (a - a0) at a = a0).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "discrete/augmented_lagrangian.hpp"

namespace rbc {
namespace {

struct Quadratic {
  double ca = 3.0, cv = -2.0;  // unconstrained minimiser
  double a = 0, v = 0;         // current point
  AugmentedLagrangianProblem problem(double k) {
    AugmentedLagrangianProblem p;
    p.area0_um2 = 1.0;
    p.volume0_um3 = 2.0;
    p.constraints.area_stiffness_pN_per_um3 = k;
    p.constraints.volume_stiffness_pN_per_um5 = k;
    p.constraints.tolerance = 1e-10;
    p.minimise = [this, p](const ConstraintMultipliers& l, double s) {
      const double ka = s * p.constraints.area_stiffness_pN_per_um3;
      const double kv = s * p.constraints.volume_stiffness_pN_per_um5;
      a = (ca + ka * p.area0_um2 - l.area_pN_per_um) / (1.0 + ka);
      v = (cv + kv * p.volume0_um3 - l.volume_pN_per_um2) / (1.0 + kv);
      MinimiserResult r;
      r.status = MinimiserStatus::converged;
      r.iterations = 1;
      return r;
    };
    p.measure = [this] { return ConstraintState{a, v}; };
    return p;
  }
};

TEST(AugmentedLagrangian, ReachesTheExactMultipliersWithoutStiffeningWhenThePenaltyIsStiff) {
  // Violation after an update falls by 1/(1 + s k) = 1/101 < 0.25: no stiffening.
  Quadratic q;
  ConstraintMultipliers l;
  double s = 1.0;
  const auto r = run_augmented_lagrangian(q.problem(100.0), 40, {}, l, s);
  EXPECT_EQ(r.stop, AugmentedLagrangianStop::converged);
  // Multiplier error = (1 + s k) x violation < 101 x 1e-10.
  EXPECT_NEAR(l.area_pN_per_um, q.ca - 1.0, 2e-8);
  EXPECT_NEAR(l.volume_pN_per_um2, q.cv - 2.0, 2e-8);
  EXPECT_EQ(s, 1.0);
  EXPECT_LT(std::abs(q.a - 1.0), 1e-10);
  // Geometric convergence at rate 1/101 from a violation of order 1: 1e-10 in 5-6 updates.
  EXPECT_LE(r.minimisations, 7);
  EXPECT_EQ(r.iterations, r.minimisations);
}

TEST(AugmentedLagrangian, StiffensTenfoldWhenTheViolationFallsLessThanFourfold) {
  // s k = 1: the violation halves per update (> 0.25), so the scale grows 10x; at s k = 10
  // it falls 11x (< 0.25) and the scale stays.
  Quadratic q;
  ConstraintMultipliers l;
  double s = 1.0;
  const auto r = run_augmented_lagrangian(q.problem(1.0), 40, {}, l, s);
  EXPECT_EQ(r.stop, AugmentedLagrangianStop::converged);
  EXPECT_NEAR(l.area_pN_per_um, q.ca - 1.0, 1e-8);
  // First update: no previous violation (infinite), no stiffening; second: halved -> x10.
  EXPECT_EQ(s, 10.0);
  AugmentedLagrangianSchedule never;
  never.stiffening_factor = 1.0;
  Quadratic q2;
  ConstraintMultipliers l2;
  double s2 = 1.0;
  const auto r2 = run_augmented_lagrangian(q2.problem(1.0), 100, never, l2, s2);
  EXPECT_EQ(r2.stop, AugmentedLagrangianStop::converged);
  EXPECT_EQ(s2, 1.0);
  EXPECT_GT(r2.minimisations, r.minimisations);  // rate 1/2 instead of 1/11
}

TEST(AugmentedLagrangian, ReportsSpentUpdatesFailuresAndBudgets) {
  Quadratic q;
  ConstraintMultipliers l;
  double s = 1.0;
  auto p = q.problem(1.0);
  const auto r = run_augmented_lagrangian(p, 2, {}, l, s);
  EXPECT_EQ(r.stop, AugmentedLagrangianStop::max_updates);
  EXPECT_EQ(r.minimisations, 2);
  EXPECT_FALSE(r.held());

  auto failing = p;
  failing.minimise = [](const ConstraintMultipliers&, double) {
    MinimiserResult m;
    m.status = MinimiserStatus::line_search_failed;
    return m;
  };
  ConstraintMultipliers l2;
  double s2 = 1.0;
  EXPECT_EQ(run_augmented_lagrangian(failing, 40, {}, l2, s2).stop,
            AugmentedLagrangianStop::minimiser_failed);
  EXPECT_EQ(l2.area_pN_per_um, 0.0);  // no update after a failure

  auto budget = p;
  budget.budget_spent = [] { return true; };
  ConstraintMultipliers l3;
  double s3 = 1.0;
  const auto r3 = run_augmented_lagrangian(budget, 40, {}, l3, s3);
  EXPECT_EQ(r3.stop, AugmentedLagrangianStop::budget_spent);
  EXPECT_EQ(r3.minimisations, 1);

  AugmentedLagrangianSchedule bad;
  bad.required_reduction = 0.0;
  EXPECT_THROW(run_augmented_lagrangian(p, 40, bad, l, s), std::invalid_argument);
  EXPECT_THROW(run_augmented_lagrangian(p, 0, {}, l, s), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
