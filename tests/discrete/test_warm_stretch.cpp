// SPDX-License-Identifier: GPL-3.0-or-later
// Warm re-solve of the discrete stretch: after a 1 % change of the persistence
// length, solving each force from the previous parameters' equilibria reaches the same
// equilibrium as the cold continuation from the rest shape, within the solver tolerance,
// in fewer minimiser iterations; a state of another mesh or other forces is refused.
#include <gtest/gtest.h>

#include <memory>

#include "core/rest_shape.hpp"
#include "discrete/stretch.hpp"

namespace rbc {
namespace {

Network cell(int n, double persistence_factor, double contact_fraction = 0.05) {
  RestShapeOptions o;
  o.target_vertices = n;
  NetworkParameters p;
  p.wlc.persistence_um *= persistence_factor;
  p.tweezers.contact_fraction = contact_fraction;
  return build_network(make_rest_shape(o), p);
}

TEST(WarmStretch, DiscreteWarmReSolveEqualsColdSolve) {
  const std::vector<double> forces{0.0, 38.0, 88.0, 193.0};
  StretchOptions so;
  so.minimiser.force_tolerance = 1e-4;
  const auto before = run_stretch(cell(250, 1.0), forces, so);
  const Network changed = cell(250, 1.01);
  const auto cold = run_stretch(changed, forces, so);
  const auto warm = run_stretch(changed, forces, so, {}, stretch_state(before));
  int cold_iterations = 0, warm_iterations = 0;
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(cold[k].converged) << cold[k].status;
    ASSERT_TRUE(warm[k].converged) << warm[k].status;
    EXPECT_TRUE(warm[k].warm);
    // Both are equilibria to 1e-4 pN per vertex; the diameters of two such states agree to
    // far better than 1e-5 relative (the stiffness is >= 1 pN/um per vertex).
    EXPECT_NEAR(warm[k].axial_um, cold[k].axial_um, 1e-5 * cold[k].axial_um);
    EXPECT_NEAR(warm[k].transverse_um, cold[k].transverse_um, 1e-5 * cold[k].transverse_um);
    // The change of persistence length moves the equilibrium: the check can fail.
    EXPECT_GT(std::abs(before[k].axial_um - cold[k].axial_um) +
                  std::abs(before[k].transverse_um - cold[k].transverse_um),
              1e-4);
    cold_iterations += cold[k].iterations;
    warm_iterations += warm[k].iterations;
  }
  EXPECT_LT(warm_iterations, cold_iterations);
}

// StretchSweepSolver keeps a preconditioner factorised at each force's equilibrium: the warm
// re-solve reaches the cold continuation's equilibria (within the tolerance, as above) without
// a single factorisation, where the plain warm run refactorises at every force start; with or
// without the mirror symmetry. The kept preconditioners were made for the old network and
// serve the new one (rebind).
void expect_kept_resolve_matches_cold(Symmetry symmetry) {
  const std::vector<double> forces{0.0, 38.0, 88.0, 193.0};
  StretchOptions so;
  so.minimiser.force_tolerance = 1e-4;
  so.symmetry = symmetry;
  StretchSweepSolver sweep(so);
  std::vector<StretchPoint> before;
  {
    const Network old_cell = cell(250, 1.0);  // gone before the warm run
    before = sweep.run(old_cell, forces);
  }
  const Network changed = cell(250, 1.01);
  const auto cold = run_stretch(changed, forces, so);
  const auto plain = run_stretch(changed, forces, so, {}, stretch_state(before));
  const auto kept = sweep.run(changed, forces, {}, stretch_state(before));
  int plain_factorisations = 0;
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(before[k].converged) << before[k].status;
    ASSERT_TRUE(kept[k].converged) << kept[k].status;
    EXPECT_NEAR(kept[k].axial_um, cold[k].axial_um, 1e-5 * cold[k].axial_um);
    EXPECT_NEAR(kept[k].transverse_um, cold[k].transverse_um, 1e-5 * cold[k].transverse_um);
    EXPECT_LE(kept[k].residual_pN, so.minimiser.force_tolerance);
    EXPECT_EQ(kept[k].factorisations, 0) << "force " << forces[k];
    if (symmetry == Symmetry::mirror) {
      EXPECT_GT(kept[k].symmetry_order, 1);
    }
    plain_factorisations += plain[k].factorisations;
  }
  EXPECT_GE(plain_factorisations, static_cast<int>(forces.size()));
}

TEST(WarmStretch, DiscreteSweepSolverReSolvesOnTheKeptPreconditioners) {
  expect_kept_resolve_matches_cold(Symmetry::none);
}

TEST(WarmStretch, DiscreteSweepSolverReSolvesOnTheKeptPreconditionersWithTheMirrorSymmetry) {
  expect_kept_resolve_matches_cold(Symmetry::mirror);
}

// A kept preconditioner serves only a network of the same mesh; its old network may be gone.
TEST(WarmStretch, KeptPreconditionerRefusesAnotherMesh) {
  const Network b = cell(500, 1.0), c = cell(250, 1.01);
  auto pre = std::make_unique<Network>(cell(250, 1.0));
  NewtonPreconditioner kept(*pre);
  ASSERT_TRUE(kept.refresh(pre->rest, {}, 1.0));
  pre.reset();  // the network it was made for is gone
  EXPECT_THROW(kept.rebind(b), std::invalid_argument);
  EXPECT_NO_THROW(kept.rebind(c));
  EXPECT_TRUE(kept.ready());
}

// Another bead patch keeps another mirror group on the same mesh (contact fraction 0.05: order
// 4, 0.07: order 2): the kept reduced preconditioners do not apply, the forces refactorise,
// and the answers are the plain warm run's.
TEST(WarmStretch, DiscreteSweepSolverRefactorisesUnderAnotherMirrorGroup) {
  const std::vector<double> forces{38.0, 88.0};
  StretchOptions so;
  so.minimiser.force_tolerance = 1e-4;
  so.symmetry = Symmetry::mirror;
  StretchSweepSolver sweep(so);
  const auto before = sweep.run(cell(250, 1.0, 0.05), forces);
  const Network other = cell(250, 1.01, 0.07);
  const auto plain = run_stretch(other, forces, so, {}, stretch_state(before));
  const auto kept = sweep.run(other, forces, {}, stretch_state(before));
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(before[k].converged);
    ASSERT_TRUE(kept[k].converged);
    EXPECT_NE(before[k].symmetry_order, kept[k].symmetry_order);
    EXPECT_EQ(kept[k].axial_um, plain[k].axial_um);
    EXPECT_GE(kept[k].factorisations, plain[k].factorisations);
  }
}

TEST(WarmStretch, DiscreteRefusesAStateOfAnotherMeshOrOtherForces) {
  const Network net = cell(250, 1.0);
  StretchState s;
  s.forces_pN = {16.0};
  s.x = {net.rest};
  s.multipliers = {{}};
  EXPECT_THROW(run_stretch(net, {38.0}, StretchOptions{}, {}, s), std::invalid_argument);
  s.x = {Positions::Zero(3, 10)};
  EXPECT_THROW(run_stretch(net, {16.0}, StretchOptions{}, {}, s), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
