// SPDX-License-Identifier: GPL-3.0-or-later
// The stretch's factorisation policy (StretchOptions::refactorise_at_force_start): keeping the
// previous force's factorisation at the start of the next one reaches the same equilibria as
// refactorising at every force start, within the solver tolerance, with fewer factorisations;
// the preconditioner's statistics count every numeric factorisation it attempted.
#include <gtest/gtest.h>

#include "core/rest_shape.hpp"
#include "discrete/stretch.hpp"

namespace rbc {
namespace {

Network cell(int n) {
  RestShapeOptions o;
  o.target_vertices = n;
  return build_network(make_rest_shape(o), NetworkParameters{});
}

TEST(StretchRefresh, KeepingTheFactorisationAcrossForcesReachesTheSameEquilibria) {
  const Network net = cell(250);
  const std::vector<double> forces{0.0, 38.0, 88.0, 130.0};
  StretchOptions fresh;
  fresh.minimiser.force_tolerance = 1e-4;
  StretchOptions kept = fresh;
  kept.refactorise_at_force_start = false;
  const auto a = run_stretch(net, forces, fresh);
  const auto b = run_stretch(net, forces, kept);
  int fa = 0, fb = 0;
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(a[k].converged) << a[k].status;
    ASSERT_TRUE(b[k].converged) << b[k].status;
    // Both are equilibria to 1e-4 pN per vertex; as in WarmStretch, two such states agree
    // to far better than 1e-5 relative in their diameters.
    EXPECT_NEAR(b[k].axial_um, a[k].axial_um, 1e-5 * a[k].axial_um);
    EXPECT_NEAR(b[k].transverse_um, a[k].transverse_um, 1e-5 * a[k].transverse_um);
    fa += a[k].factorisations;
    fb += b[k].factorisations;
  }
  // Every force but the first starts without a factorisation of its own.
  EXPECT_LT(fb, fa);
}

TEST(StretchRefresh, StatisticsCountAttemptsAndAnalyses) {
  const Network net = cell(250);
  NewtonPreconditioner pre(net);
  ConstraintMultipliers lambda;
  ASSERT_TRUE(pre.refresh(net.rest, lambda, 1.0));
  ASSERT_TRUE(pre.refresh(net.rest, lambda, 1.0));
  const auto& s = pre.statistics();
  EXPECT_EQ(s.analyses, 1);  // the symbolic analysis is done once per network
  EXPECT_EQ(s.factorisations, 2);
  EXPECT_GE(s.exact_factorisations + s.failed_attempts, s.factorisations);
  EXPECT_GT(s.factorisation_cpu_s, 0.0);
  EXPECT_GE(s.factorisation_cpu_s, s.analysis_cpu_s);
}

}  // namespace
}  // namespace rbc
