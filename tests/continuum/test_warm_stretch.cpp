// SPDX-License-Identifier: GPL-3.0-or-later
// Warm re-solve of the continuum stretch: after a 1 % change of the persistence
// length, Newton from the previous parameters' equilibria reaches the cold continuation's
// equilibrium within the solver tolerance, in fewer Newton iterations; a state of another
// mesh is refused.
#include <gtest/gtest.h>
#include <omp.h>

#include "continuum/continuum_stretch.hpp"
#include "core/parallel.hpp"
#include "fixtures.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace {

ContinuumModel model(const TriMesh& mesh, double persistence_factor) {
  WlcParameters w;
  w.persistence_um *= persistence_factor;
  return build_continuum_model(mesh, testing::closed_form_p2_law(w), ContinuumParameters{});
}

TEST(WarmStretch, ContinuumWarmReSolveEqualsColdSolve) {
  const TriMesh mesh = make_continuum_mesh(500);
  const std::vector<double> forces{0.0, 38.0, 88.0, 193.0};
  ContinuumOptions co;
  const auto before = run_continuum_stretch(model(mesh, 1.0), forces, co);
  const ContinuumModel changed = model(mesh, 1.01);
  const auto cold = run_continuum_stretch(changed, forces, co);
  const auto warm = run_continuum_stretch(changed, forces, co, {}, stretch_state(before));
  int cold_iterations = 0, warm_iterations = 0;
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(cold[k].converged) << to_string(cold[k].status);
    ASSERT_TRUE(warm[k].converged) << to_string(warm[k].status);
    EXPECT_TRUE(warm[k].warm);
    // Newton converges to 1e-6 pN per vertex: the two equilibria agree to that tolerance over
    // the softest stiffness (~1 pN/um at 0 pN: ~1e-6 um; measured 2.9e-7 um with the lagged
    // Krylov chord steps, which stop nearer the tolerance than full Newton steps).
    EXPECT_NEAR(warm[k].axial_um, cold[k].axial_um, 1e-7 * cold[k].axial_um);
    EXPECT_NEAR(warm[k].transverse_um, cold[k].transverse_um, 1e-7 * cold[k].transverse_um);
    EXPECT_NEAR(warm[k].multipliers.area_pN_per_um, cold[k].multipliers.area_pN_per_um,
                1e-6 * (1 + std::abs(cold[k].multipliers.area_pN_per_um)));
    EXPECT_GT(std::abs(before[k].axial_um - cold[k].axial_um) +
                  std::abs(before[k].transverse_um - cold[k].transverse_um),
              1e-4);
    cold_iterations += cold[k].iterations;
    warm_iterations += warm[k].iterations;
  }
  EXPECT_LT(warm_iterations, cold_iterations);
}

// ContinuumSweepSolver keeps a factorisation at each force's equilibrium: the warm re-solve
// reaches the same equilibria as the cold continuation (within the solver tolerance)
// on chord steps alone, where the plain warm run factorises at every force; with or without
// the mirror symmetry.
void expect_kept_resolve_matches_cold(Symmetry symmetry) {
  const TriMesh mesh = make_continuum_mesh(500);
  const std::vector<double> forces{0.0, 38.0, 88.0, 193.0};
  ContinuumOptions co;
  co.newton.symmetry = symmetry;
  const ContinuumModel m0 = model(mesh, 1.0), m1 = model(mesh, 1.01);
  ContinuumSweepSolver sweep(co);
  const auto before = sweep.run(m0, forces);
  const auto cold = run_continuum_stretch(m1, forces, co);
  const auto plain = run_continuum_stretch(m1, forces, co, {}, stretch_state(before));
  const auto kept = sweep.run(m1, forces, {}, stretch_state(before));
  int plain_factorisations = 0, kept_factorisations = 0;
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(before[k].converged) << to_string(before[k].status);
    ASSERT_TRUE(kept[k].converged) << to_string(kept[k].status);
    ASSERT_TRUE(plain[k].converged) << to_string(plain[k].status);
    EXPECT_EQ(kept[k].substeps, 1);  // the warm solve itself converged
    // Chord steps stop just under the 1e-6 pN tolerance: over the softest stiffness at 0 pN
    // (~0.5 pN/um) that is ~2e-6 um (measured 2.0e-6 um with the mirror symmetry).
    EXPECT_NEAR(kept[k].axial_um, cold[k].axial_um, 5e-7 * cold[k].axial_um);
    EXPECT_NEAR(kept[k].transverse_um, cold[k].transverse_um, 5e-7 * cold[k].transverse_um);
    EXPECT_NEAR(kept[k].multipliers.area_pN_per_um, cold[k].multipliers.area_pN_per_um,
                1e-6 * (1 + std::abs(cold[k].multipliers.area_pN_per_um)));
    EXPECT_LE(kept[k].residual_pN, co.newton.force_tolerance_pN);
    plain_factorisations += plain[k].factorisations;
    kept_factorisations += kept[k].factorisations - plain[k].factorisations;
  }
  // The plain run factorises at least once per force; the kept one only for the symmetry check
  // (the same sector factorisations as the plain run's, hence the difference).
  EXPECT_GE(plain_factorisations, static_cast<int>(forces.size()));
  EXPECT_LE(kept_factorisations, -static_cast<int>(forces.size()));
}

TEST(WarmStretch, SweepSolverReSolvesOnTheKeptFactorisations) {
  expect_kept_resolve_matches_cold(Symmetry::none);
}

TEST(WarmStretch, SweepSolverReSolvesOnTheKeptFactorisationsWithTheMirrorSymmetry) {
  expect_kept_resolve_matches_cold(Symmetry::mirror);
}

// Another force list drops what is kept: a warm run then is the plain warm run, bit for bit.
TEST(WarmStretch, SweepSolverForgetsTheFactorisationsOfAnotherForceList) {
  const TriMesh mesh = make_continuum_mesh(500);
  const ContinuumModel m0 = model(mesh, 1.0), m1 = model(mesh, 1.01);
  const ContinuumOptions co;
  ContinuumSweepSolver sweep(co);
  sweep.run(m0, {0.0, 38.0, 88.0});
  const std::vector<double> others{0.0, 38.0, 67.6};  // same length, one force changed
  const StretchState before = stretch_state(run_continuum_stretch(m0, others, co));
  const auto plain = run_continuum_stretch(m1, others, co, {}, before);
  const auto kept = sweep.run(m1, others, {}, before);
  for (size_t k = 0; k < others.size(); ++k) {
    ASSERT_TRUE(kept[k].converged);
    EXPECT_EQ(kept[k].axial_um, plain[k].axial_um);
    EXPECT_EQ(kept[k].transverse_um, plain[k].transverse_um);
    EXPECT_EQ(kept[k].iterations, plain[k].iterations);
    // ... plus the factorisation at the new equilibrium, kept for the next run.
    EXPECT_EQ(kept[k].factorisations, plain[k].factorisations + 1);
  }
}

TEST(WarmStretch, ContinuumRefusesAStateOfAnotherMesh) {
  const ContinuumModel m = model(make_continuum_mesh(500), 1.0);
  const ContinuumModel other = model(make_continuum_mesh(1000), 1.0);
  StretchState s;
  s.forces_pN = {16.0};
  s.x = {other.rest};
  s.multipliers = {{}};
  EXPECT_THROW(run_continuum_stretch(m, {16.0}, ContinuumOptions{}, {}, s), std::invalid_argument);
}

TEST(DeterministicSums, ContinuumEnergyGradientAndConstraintsBitIdenticalWithOneTwoThreeThreads) {
  // 9,000+ elements: several chunks in core/parallel.hpp, so the parallel path is tested.
  const ContinuumModel m = model(make_continuum_mesh(9680), 1.0);
  ASSERT_GT(assembly_chunks(m.num_elements()), 1);
  Positions x = m.rest;
  testing::perturb(x, 0.01, 5);
  double e[3], a[3];
  Positions g[3], ga[3];
  const int saved = omp_get_max_threads();
  for (int t = 1; t <= 3; ++t) {
    omp_set_num_threads(t);
    e[t - 1] = continuum_energy(m, x, 88.0, &g[t - 1]);
    const ConstraintValues c = evaluate_constraints(x, m.topo);
    a[t - 1] = c.area_um2;
    ga[t - 1] = c.grad_area;
  }
  omp_set_num_threads(saved);
  for (int t = 1; t < 3; ++t) {
    EXPECT_EQ(e[t], e[0]);
    EXPECT_EQ(a[t], a[0]);
    EXPECT_TRUE((g[t].array() == g[0].array()).all());
    EXPECT_TRUE((ga[t].array() == ga[0].array()).all());
  }
}

}  // namespace
}  // namespace rbc
