// SPDX-License-Identifier: GPL-3.0-or-later
// Budgets of the cell problem (reliability case 31: `rbc moduli --cells 100` ran all 200 Newton
// iterations at 1.1e-10 pN against a 1e-10 pN tolerance): a relaxation whose residual stalls at
// the round-off floor ends there, with the affine map recovered (Theorem 3) and the floor
// flagged; without the rule it runs to its iteration limit; the cancel hook stops it.
#include <gtest/gtest.h>

#include <random>

#include "homogenise/periodic_network.hpp"

namespace rbc {
namespace {

Eigen::Matrix2Xd random_start(int n, double amplitude, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amplitude, amplitude);
  Eigen::Matrix2Xd U(2, n);
  for (int i = 0; i < U.size(); ++i) U.data()[i] = u(rng);
  return U;
}

struct Scene {
  NetworkMaterial m = make_network_material(WlcParameters{}, StericParameters{});
  double a = 0.075;
  PeriodicNetwork net = make_hexagonal_patch(6, a);
  Eigen::Matrix2d F = (Eigen::Matrix2d() << 1.3, 0.2, -0.1, 0.9).finished();
  Eigen::Matrix2Xd U0 = random_start(net.vertex_count(), 0.1 * a, 11);
};

TEST(CellProblemBudget, UnreachableToleranceEndsAtTheRoundOffFloorWithTheAffineMap) {
  const Scene s;
  RelaxOptions o;
  o.force_tolerance_pN = 1e-30;  // below any double sum of pN-sized forces
  o.floor_factor = 1e22;         // accept a floor up to 1e-8 pN
  const CellRelaxResult r = relax_patch(s.net, s.m, s.F, s.U0, o);
  ASSERT_TRUE(r.converged()) << to_string(r.status) << " residual " << r.residual_pN;
  EXPECT_TRUE(r.at_roundoff_floor);
  EXPECT_LT(r.iterations, 40);                   // Newton: quadratic, then stall_iterations more
  EXPECT_LT(r.residual_pN, 1e-8);                // the best iterate is returned
  EXPECT_LT(r.max_displacement_um, 1e-9 * s.a);  // Theorem 3: the affine map is the minimiser
}

TEST(CellProblemBudget, WithoutTheFloorRuleTheSameRunUsesItsWholeBudget) {
  const Scene s;
  RelaxOptions o;
  o.force_tolerance_pN = 1e-30;
  o.floor_factor = 0;  // never accept a floor
  o.max_iterations = 40;
  const CellRelaxResult r = relax_patch(s.net, s.m, s.F, s.U0, o);
  EXPECT_EQ(r.status, MinimiserStatus::max_iterations);
  EXPECT_EQ(r.iterations, 40);
  EXPECT_FALSE(r.at_roundoff_floor);
}

TEST(CellProblemBudget, ReachableToleranceIsNotReportedAsAFloor) {
  const Scene s;
  const CellRelaxResult r = relax_patch(s.net, s.m, s.F, s.U0);  // 1e-10 pN at 36 vertices
  ASSERT_TRUE(r.converged());
  EXPECT_FALSE(r.at_roundoff_floor);
  EXPECT_LE(r.residual_pN, 1e-10);
}

TEST(CellProblemBudget, CancelHookStopsTheRelaxation) {
  const Scene s;
  RelaxOptions o;
  int polls = 0;
  o.cancel = [&] { return ++polls > 2; };
  EXPECT_THROW(relax_patch(s.net, s.m, s.F, s.U0, o), Cancelled);
  EXPECT_EQ(polls, 3);
}

}  // namespace
}  // namespace rbc
