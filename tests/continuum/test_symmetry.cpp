// SPDX-License-Identifier: GPL-3.0-or-later
// The continuum stretch on the mirror-symmetric states (NewtonOptions::symmetry,
// core/mirror_symmetry.hpp) against the full problem: the same equilibria within the Newton
// tolerance at every force, the reported residual is the full problem's (to rounding where the
// state is not checked), a soft cell that
// buckles (the symmetric state is a saddle) is caught by the stability check and solved in
// full, and a mesh without a mirror is solved in full.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include "continuum/continuum_stretch.hpp"

#include "continuum/reduced_hessian.hpp"
#include "continuum/symmetric_energy.hpp"
#include "core/mirror_symmetry.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace {

ContinuumModel model(const TriMesh& mesh, const WlcParameters& w = {}) {
  return build_continuum_model(mesh, testing::closed_form_p2_law(w), ContinuumParameters{});
}

/// Both runs converged and at the same equilibrium within the Newton tolerance (1e-6 pN per
/// vertex over the softest stiffness, ~1 pN/um: ~1e-6 um, 1e-7 of a diameter).
void expect_same(const std::vector<ContinuumStretchPoint>& a,
                 const std::vector<ContinuumStretchPoint>& b, double tolerance_pN) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) {
    const double f = a[k].force_pN;
    ASSERT_TRUE(a[k].converged) << f << " pN: " << to_string(a[k].status);
    ASSERT_TRUE(b[k].converged) << f << " pN: " << to_string(b[k].status);
    // At 0 pN a rigid turn about z costs nothing and moves the extents of the (not exactly
    // round) mesh: the full solve's tiny Levenberg shift leaves it at ~1e-6 um.
    const double rel = f == 0.0 ? 1e-6 : 1e-7;
    EXPECT_NEAR(b[k].axial_um, a[k].axial_um, rel * a[k].axial_um) << f << " pN";
    EXPECT_NEAR(b[k].transverse_um, a[k].transverse_um, rel * a[k].transverse_um) << f << " pN";
    EXPECT_NEAR(b[k].energy_pNum, a[k].energy_pNum, 1e-8 * (1 + std::abs(a[k].energy_pNum)));
    EXPECT_NEAR(b[k].multipliers.area_pN_per_um, a[k].multipliers.area_pN_per_um,
                1e-5 * (1 + std::abs(a[k].multipliers.area_pN_per_um)));
    // The full problem's largest net vertex force.
    EXPECT_LE(b[k].residual_pN, tolerance_pN);
    EXPECT_LT(std::abs(b[k].area_drift), 1e-9);
    EXPECT_LT(std::abs(b[k].volume_drift), 1e-9);
  }
}

ContinuumOptions mirror_options(bool check = true) {
  ContinuumOptions o;
  o.newton.symmetry = Symmetry::mirror;
  o.newton.symmetry_check = check;
  return o;
}

/// A model of `mesh` (H0 != 0, the bead patch's own mirrors) at a symmetric, strained state:
/// the rest shape symmetrically perturbed (seeded) and stretched 20 % along x.
struct SymmetricScene {
  ContinuumModel model;
  MeshSymmetry group;
  SymmetryReduction reduction;
  Positions x;
  SymmetricScene(const TriMesh& mesh, bool level_patch, unsigned seed) {
    WlcParameters w;
    ContinuumParameters cp;
    cp.bending.h0_per_um = 0.3;
    cp.tweezers.keep_equal_x_together = level_patch;
    model = build_continuum_model(mesh, testing::closed_form_p2_law(w), cp);
    group = tweezers_scene_symmetry(model.rest, model.topo, model.patch);
    reduction = make_symmetry_reduction(group);
    std::mt19937 rng(seed);
    std::normal_distribution<double> nd(0.0, 0.01);
    Eigen::VectorXd q = symmetric_part(reduction, flat(model.rest));
    for (auto& v : q) v += nd(rng);
    x.resize(3, model.rest.cols());
    flat(x) = expand(reduction, q);
    x.row(0) *= 1.2;
  }
};

/// The Hessian from representative elements against reducing the full one, on the trivial
/// sector and every other (the stability check's matrices), at a symmetric, strained state of
/// `mesh` (the rest shape stretched 20 % along x and symmetrically perturbed), with multipliers
/// and H0 != 0 so that every term contributes.
void expect_representative_hessian_is_the_reduced_one(const TriMesh& mesh, bool level_patch,
                                                      int order) {
  const SymmetricScene scene(mesh, level_patch, 2);
  const auto& [m, g, red, x] = scene;
  ASSERT_EQ(g.order(), order);
  BlockHessian full(m.topo, BlockStorage::lower);
  add_lagrangian_hessian(m, x, 0.7, -0.2, full);
  ReducedMatrix map(red, full.matrix());
  const Eigen::SparseMatrix<double> expected = map.reduce(full.matrix());
  ReducedLagrangianHessian direct(m, g, red);
  EXPECT_LT(direct.representative_faces(), m.num_elements() / 3);
  const Eigen::SparseMatrix<double>& got = direct.assemble(x, 0.7, -0.2);
  // The same pattern (built here from the representative elements' orbits, there from the
  // full matrix) and the same values.
  ASSERT_EQ(got.nonZeros(), expected.nonZeros());
  ASSERT_TRUE(std::equal(got.outerIndexPtr(), got.outerIndexPtr() + got.outerSize() + 1,
                         expected.outerIndexPtr()));
  ASSERT_TRUE(std::equal(got.innerIndexPtr(), got.innerIndexPtr() + got.nonZeros(),
                         expected.innerIndexPtr()));
  double largest = 0.0, diff = 0.0;
  for (Eigen::Index k = 0; k < got.nonZeros(); ++k) {
    largest = std::max(largest, std::abs(expected.valuePtr()[k]));
    diff = std::max(diff, std::abs(got.valuePtr()[k] - expected.valuePtr()[k]));
  }
  EXPECT_LT(diff, 1e-11 * largest);
  const std::vector<int> chars = nontrivial_characters(g);
  EXPECT_EQ(static_cast<int>(chars.size()), order - 1);
  std::vector<SymmetryReduction> sectors;
  for (int c : chars) sectors.push_back(make_symmetry_reduction(g, c));
  for (const auto& sr : sectors) direct.add_sector(sr);
  direct.assemble_sectors(x, 0.7, -0.2);
  for (size_t k = 0; k < sectors.size(); ++k) {
    ReducedMatrix sector_map(sectors[k], full.matrix());
    const Eigen::SparseMatrix<double> want = sector_map.reduce(full.matrix());
    const Eigen::SparseMatrix<double>& have = direct.sector(static_cast<int>(k));
    ASSERT_EQ(have.nonZeros(), want.nonZeros());
    ASSERT_TRUE(std::equal(have.outerIndexPtr(), have.outerIndexPtr() + have.outerSize() + 1,
                           want.outerIndexPtr()));
    ASSERT_TRUE(std::equal(have.innerIndexPtr(), have.innerIndexPtr() + have.nonZeros(),
                           want.innerIndexPtr()));
    double d = 0.0;
    for (Eigen::Index i = 0; i < have.nonZeros(); ++i)
      d = std::max(d, std::abs(have.valuePtr()[i] - want.valuePtr()[i]));
    EXPECT_LT(d, 1e-11 * largest) << "character " << chars[k];
  }
}

TEST(ContinuumSymmetry, RepresentativeElementHessianEqualsTheReducedFullHessian) {
  expect_representative_hessian_is_the_reduced_one(make_continuum_mesh(2000), false, 4);
  // All eight mirrors; at this even icosphere frequency (10) a vertex sits on each coordinate
  // axis, with two coordinates pinned in the symmetric sector and all three in some others.
  expect_representative_hessian_is_the_reduced_one(
      make_continuum_mesh(2000, 0, TriangulationOrientation::mirror_planes), true, 8);
}

/// The energy, reduced gradient and constraints from one element per orbit (continuum/
/// symmetric_energy.hpp) against the full ones reduced, at the same kind of symmetric strained
/// state as the Hessian test, with a bead force and H0 != 0 so that every term contributes;
/// and the collapsed state refused as continuum_energy refuses it.
void expect_representative_energy_is_the_full_one(const TriMesh& mesh, bool level_patch,
                                                  int order) {
  const SymmetricScene scene(mesh, level_patch, 3);
  const auto& [m, g, red, x] = scene;
  ASSERT_EQ(g.order(), order);
  const double force_pN = 50.0;
  Positions g_full;
  const double e_full = continuum_energy(m, x, force_pN, &g_full);
  const ConstraintValues c_full = evaluate_constraints(x, m.topo);
  const ReducedLagrangianHessian orbits(m, g, red);
  SymmetricContinuumEnergy sym(m, orbits);
  Positions g_sym;
  ConstraintValues c_sym;
  const double e_sym = sym.evaluate(x, force_pN, g_sym, c_sym);
  EXPECT_NEAR(e_sym, e_full, 1e-12 * std::abs(e_full));
  EXPECT_NEAR(c_sym.area_um2, c_full.area_um2, 1e-12 * c_full.area_um2);
  EXPECT_NEAR(c_sym.volume_um3, c_full.volume_um3, 1e-12 * c_full.volume_um3);
  // Only the reductions agree: the representatives' gradient lives on their vertices.
  const auto expect_same_reduction = [&](const Positions& have, const Positions& want,
                                         const char* what) {
    const Eigen::VectorXd a = reduce(red, Eigen::VectorXd(flat(have)));
    const Eigen::VectorXd b = reduce(red, Eigen::VectorXd(flat(want)));
    EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-10 * b.cwiseAbs().maxCoeff()) << what;
    EXPECT_GT((flat(have) - flat(want)).cwiseAbs().maxCoeff(), 1e-3 * b.cwiseAbs().maxCoeff())
        << what << ": the full vectors differ off the representatives";
  };
  expect_same_reduction(g_sym, g_full, "energy gradient");
  expect_same_reduction(c_sym.grad_area, c_full.grad_area, "area gradient");
  expect_same_reduction(c_sym.grad_volume, c_full.grad_volume, "volume gradient");
  // A collapsed state: +infinity, as the full energy.
  const Positions collapsed = Positions::Zero(3, m.rest.cols());
  EXPECT_EQ(continuum_energy(m, collapsed, force_pN), std::numeric_limits<double>::infinity());
  EXPECT_EQ(sym.evaluate(collapsed, force_pN, g_sym, c_sym),
            std::numeric_limits<double>::infinity());
}

TEST(ContinuumSymmetry, RepresentativeElementEnergyEqualsTheFullEnergyReduced) {
  expect_representative_energy_is_the_full_one(make_continuum_mesh(2000), false, 4);
  expect_representative_energy_is_the_full_one(
      make_continuum_mesh(2000, 0, TriangulationOrientation::mirror_planes), true, 8);
}

TEST(ContinuumSymmetry, MirrorReducedStretchEqualsTheFullOne) {
  // 2,000 elements: the bead patch keeps all four mirrors of the mesh; 1,000 elements: its edge
  // splits a y -> -y pair, two are left (the inversion and the identity).
  for (const auto& [elements, order] : {std::pair{2000, 4}, std::pair{1000, 2}}) {
    const ContinuumModel m = model(make_continuum_mesh(elements));
    EXPECT_EQ(NewtonSolver(m, mirror_options().newton).symmetry_order(), order);
    const std::vector<double> forces{0.0, 38.0, 88.0, 193.0};
    const auto full = run_continuum_stretch(m, forces, ContinuumOptions{});
    const auto reduced = run_continuum_stretch(m, forces, mirror_options());
    expect_same(full, reduced, ContinuumOptions{}.newton.force_tolerance_pN);
    for (const auto& p : reduced) {
      EXPECT_EQ(p.symmetry_order, order);
      EXPECT_FALSE(p.symmetry_broken);
      // The shape is symmetric: its centre stays at the origin (inversion).
      EXPECT_LT(p.x.rowwise().mean().norm(), 1e-9);
    }
  }
}

TEST(ContinuumSymmetry, MirrorReducedStretchOnTheMirrorPlanesMeshEqualsTheFullOne) {
  // One eighth of the cell (980 elements, odd frequency 7: no vertex on the axes).
  ContinuumParameters cp;
  cp.tweezers.keep_equal_x_together = true;
  const ContinuumModel m =
      build_continuum_model(make_continuum_mesh(1000, 0, TriangulationOrientation::mirror_planes),
                            testing::closed_form_p2_law(WlcParameters{}), cp);
  EXPECT_EQ(NewtonSolver(m, mirror_options().newton).symmetry_order(), 8);
  const std::vector<double> forces{0.0, 88.0, 193.0};
  const auto full = run_continuum_stretch(m, forces, ContinuumOptions{});
  const auto reduced = run_continuum_stretch(m, forces, mirror_options());
  expect_same(full, reduced, ContinuumOptions{}.newton.force_tolerance_pN);
  for (const auto& p : reduced) {
    EXPECT_EQ(p.symmetry_order, 8);
    EXPECT_FALSE(p.symmetry_broken);
    // Each coordinate mirror maps the shape onto itself: its centre stays at the origin.
    EXPECT_LT(p.x.rowwise().mean().norm(), 1e-9);
  }
}

/// The soft corner of the calibration's prior (p 25 nm, Lmax 364 nm), which buckles.
WlcParameters soft_corner() {
  WlcParameters w;
  w.persistence_um = 0.025;
  w.lmax_um = 0.364;
  return w;
}

TEST(ContinuumSymmetry, BucklingSoftCellIsCaughtAndSolvedInFull) {
  // The soft corner of the calibration's prior (p 25 nm, Lmax 364 nm): between 38 and 67.6 pN
  // the stretched cell buckles, breaking y -> -y by ~0.5 um (the inversion stays). The full
  // solve follows the buckled branch; the symmetric state there is a saddle of higher energy.
  const ContinuumModel m = model(make_continuum_mesh(500), soft_corner());
  const std::vector<double> forces{0.0, 38.0, 67.6, 151.0};
  const auto full = run_continuum_stretch(m, forces, ContinuumOptions{});
  const auto checked = run_continuum_stretch(m, forces, mirror_options(true));
  const auto trusted = run_continuum_stretch(m, forces, mirror_options(false));
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(full[k].converged) << forces[k];
    ASSERT_TRUE(checked[k].converged) << forces[k];
    ASSERT_TRUE(trusted[k].converged) << forces[k];
  }
  // Before the buckling: symmetric, the same state as the full solve.
  EXPECT_FALSE(checked[1].symmetry_broken);
  EXPECT_NEAR(checked[1].axial_um, full[1].axial_um, 1e-7 * full[1].axial_um);
  EXPECT_NEAR(checked[1].energy_pNum, full[1].energy_pNum, 1e-8 * std::abs(full[1].energy_pNum));
  // After it: the check finds the saddle; the full solve from the pushed state reaches a
  // buckled minimum. Past a bifurcation several buckled minima exist (the push and the full
  // continuation's round-off pick different ones: measured 0.009 pN um and 0.08 % in D_T
  // apart at 67.6 pN), so the checked answer is compared with the full one to 0.5 %, and
  // both lie well below the saddle the unchecked symmetric solve reports.
  for (size_t k : {size_t{2}, size_t{3}}) {
    EXPECT_TRUE(checked[k].symmetry_broken) << forces[k];
    EXPECT_EQ(checked[k].symmetry_order, 1);
    EXPECT_NEAR(checked[k].axial_um, full[k].axial_um, 5e-3 * full[k].axial_um) << forces[k];
    EXPECT_NEAR(checked[k].transverse_um, full[k].transverse_um, 5e-3 * full[k].transverse_um);
    EXPECT_LT(checked[k].energy_pNum, trusted[k].energy_pNum - 0.05) << forces[k];
    EXPECT_LT(full[k].energy_pNum, trusted[k].energy_pNum - 0.05) << forces[k];
    EXPECT_FALSE(trusted[k].symmetry_broken);
  }
  // The saddle's diameters are off by more than the Mills error bars' resolution.
  EXPECT_GT(std::abs(trusted[2].axial_um - full[2].axial_um), 0.03);
}

ContinuumOptions highest_force_check() {
  ContinuumOptions o = mirror_options(true);
  o.symmetry_check_at = SymmetryCheckAt::highest_force;
  return o;
}

TEST(ContinuumSymmetry, HighestForceCheckLeavesStableStatesAndSavesTheLowerForcesChecks) {
  // Where nothing buckles, checking only the highest force's equilibrium changes no state (the
  // check only reads it) and spares each lower force its |G| - 1 sector factorisations.
  const ContinuumModel m = model(make_continuum_mesh(500));
  const std::vector<double> forces{0.0, 38.0, 87.6};
  const auto every = run_continuum_stretch(m, forces, mirror_options(true));
  const auto highest = run_continuum_stretch(m, forces, highest_force_check());
  ASSERT_EQ(every.size(), highest.size());
  const int sectors = every[0].factorisations - highest[0].factorisations;
  EXPECT_GT(sectors, 0);
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(highest[k].converged) << forces[k];
    EXPECT_FALSE(highest[k].symmetry_broken);
    EXPECT_GT(highest[k].symmetry_order, 1);
    EXPECT_EQ((highest[k].x - every[k].x).cwiseAbs().maxCoeff(), 0.0) << forces[k];
    EXPECT_EQ(highest[k].iterations, every[k].iterations);
    // An unchecked force reports the reduced solve's residual, energy and drifts (no full
    // evaluation: the mesh is symmetric to rounding); the checked run's come from the full
    // problem at the same state. Equal to rounding.
    EXPECT_NEAR(highest[k].residual_pN, every[k].residual_pN, 1e-12 + 1e-9 * every[k].residual_pN)
        << forces[k];
    EXPECT_NEAR(highest[k].energy_pNum, every[k].energy_pNum,
                1e-12 * std::abs(every[k].energy_pNum))
        << forces[k];
    EXPECT_NEAR(highest[k].area_drift, every[k].area_drift, 1e-14) << forces[k];
    EXPECT_NEAR(highest[k].volume_drift, every[k].volume_drift, 1e-14) << forces[k];
    // Each lower force saves one set of sector factorisations; the highest is checked alike.
    EXPECT_EQ(every[k].factorisations - highest[k].factorisations,
              k + 1 < forces.size() ? sectors : 0)
        << forces[k];
  }
}

TEST(ContinuumSymmetry, HighestForceCheckFindsTheBucklingAndAnswersAsEveryForce) {
  // The soft cell of BucklingSoftCellIsCaughtAndSolvedInFull: the highest force's symmetric
  // state is a saddle, so the sweep runs again with every force checked and answers as that
  // policy does, bit for bit, counting both passes' work. With the forces below the buckling
  // only, the one check passes.
  const ContinuumModel m = model(make_continuum_mesh(500), soft_corner());
  const std::vector<double> forces{0.0, 38.0, 67.6, 151.0};
  const auto every = run_continuum_stretch(m, forces, mirror_options(true));
  const auto highest = run_continuum_stretch(m, forces, highest_force_check());
  ASSERT_EQ(every.size(), highest.size());
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(highest[k].converged) << forces[k];
    EXPECT_EQ(highest[k].symmetry_broken, every[k].symmetry_broken) << forces[k];
    EXPECT_EQ((highest[k].x - every[k].x).cwiseAbs().maxCoeff(), 0.0) << forces[k];
    EXPECT_GT(highest[k].iterations, every[k].iterations) << forces[k];
    EXPECT_GT(highest[k].factorisations, every[k].factorisations) << forces[k];
  }
  EXPECT_TRUE(highest[3].symmetry_broken);
  // The same through a ContinuumSweepSolver, whose second pass runs on the kept solver.
  ContinuumSweepSolver kept_highest(highest_force_check()), kept_every(mirror_options(true));
  const auto a = kept_highest.run(m, forces);
  const auto b = kept_every.run(m, forces);
  for (size_t k = 0; k < forces.size(); ++k) {
    EXPECT_EQ(a[k].symmetry_broken, b[k].symmetry_broken) << forces[k];
    EXPECT_EQ((a[k].x - b[k].x).cwiseAbs().maxCoeff(), 0.0) << forces[k];
  }
  const std::vector<double> below{0.0, 38.0};
  const auto stable = run_continuum_stretch(m, below, highest_force_check());
  const auto trusted = run_continuum_stretch(m, below, mirror_options(false));
  for (size_t k = 0; k < below.size(); ++k) {
    EXPECT_FALSE(stable[k].symmetry_broken);
    EXPECT_EQ(stable[k].iterations, trusted[k].iterations);
    EXPECT_EQ((stable[k].x - trusted[k].x).cwiseAbs().maxCoeff(), 0.0);
  }
}

/// The same points bit for bit (not only within the tolerance).
void expect_identical(const std::vector<ContinuumStretchPoint>& a,
                      const std::vector<ContinuumStretchPoint>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].converged, b[k].converged) << a[k].force_pN;
    EXPECT_EQ(a[k].iterations, b[k].iterations) << a[k].force_pN;
    EXPECT_EQ(a[k].symmetry_broken, b[k].symmetry_broken) << a[k].force_pN;
    EXPECT_EQ((a[k].x - b[k].x).cwiseAbs().maxCoeff(), 0.0) << a[k].force_pN;
    EXPECT_EQ(a[k].multipliers.area_pN_per_um, b[k].multipliers.area_pN_per_um);
  }
}

TEST(ContinuumSymmetry, ReboundSolverSolvesTheNextModelAsANewSolverBitForBit) {
  // NewtonSolver::rebind keeps the mesh's set-up (patterns, analyses, mirror reductions,
  // stability sectors) for a model of other parameters and starts it as new: on the mirror-planes
  // mesh (8 sectors), a solve after rebinding equals a new solver's, bit for bit.
  ContinuumParameters cp;
  cp.tweezers.keep_equal_x_together = true;
  const TriMesh mesh = make_continuum_mesh(1000, 0, TriangulationOrientation::mirror_planes);
  WlcParameters w1;
  w1.persistence_um *= 1.01;
  auto m0 = std::make_unique<ContinuumModel>(
      build_continuum_model(mesh, testing::closed_form_p2_law(WlcParameters{}), cp));
  const ContinuumModel m1 = build_continuum_model(mesh, testing::closed_form_p2_law(w1), cp);
  const NewtonOptions o = mirror_options().newton;
  NewtonSolver kept(*m0, o);
  Positions x0 = m0->rest;
  ConstraintMultipliers l0;
  ASSERT_TRUE(kept.solve(88.0, x0, l0).converged());
  m0.reset();  // the model of the last solve may be gone before the next is bound
  ASSERT_TRUE(kept.same_mesh(m1));
  kept.rebind(m1);
  Positions xa = m1.rest, xb = m1.rest;
  ConstraintMultipliers la, lb;
  const NewtonResult a = kept.solve(88.0, xa, la);
  NewtonSolver fresh(m1, o);
  const NewtonResult b = fresh.solve(88.0, xb, lb);
  ASSERT_TRUE(a.converged());
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.factorisations, b.factorisations);
  EXPECT_EQ(a.stability_factorisations, b.stability_factorisations);
  EXPECT_EQ(b.stability_factorisations, 7);
  EXPECT_EQ((xa - xb).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(la.area_pN_per_um, lb.area_pN_per_um);
  // Another mesh is refused.
  const ContinuumModel other = model(make_continuum_mesh(500));
  EXPECT_FALSE(kept.same_mesh(other));
  EXPECT_THROW(kept.rebind(other), std::invalid_argument);
}

TEST(ContinuumSymmetry, KeptSweepSolverRunsTheNextModelAsANewOneThroughTheBuckling) {
  // ContinuumSweepSolver keeps its NewtonSolver between runs on one mesh. A cold run of the
  // soft cell that buckles (its full Hessian built only then) after a run of the stiff one equals
  // the soft cell's run on a new sweep solver, bit for bit.
  const TriMesh mesh = make_continuum_mesh(500);
  const ContinuumModel stiff = model(mesh), buckling = model(mesh, soft_corner());
  const std::vector<double> forces{0.0, 38.0, 67.6};
  ContinuumSweepSolver reused(mirror_options());
  const auto first = reused.run(stiff, forces);
  for (const auto& p : first) ASSERT_TRUE(p.converged);
  const auto again = reused.run(buckling, forces);
  ContinuumSweepSolver fresh(mirror_options());
  const auto expected = fresh.run(buckling, forces);
  EXPECT_TRUE(expected[2].symmetry_broken);
  expect_identical(again, expected);
}

TEST(ContinuumSymmetry, MeshWithoutAMirrorIsSolvedInFull) {
  TriMesh mesh = make_continuum_mesh(500);
  mesh.x(2, 7) += 1e-6;  // 100 x the mirror tolerance
  const ContinuumModel m = model(mesh);
  EXPECT_EQ(NewtonSolver(m, mirror_options().newton).symmetry_order(), 1);
  const auto a = run_continuum_stretch(m, {88.0}, ContinuumOptions{});
  const auto b = run_continuum_stretch(m, {88.0}, mirror_options());
  EXPECT_EQ(a[0].axial_um, b[0].axial_um);  // the same computation
  EXPECT_EQ(a[0].iterations, b[0].iterations);
  EXPECT_EQ(b[0].symmetry_order, 1);
}

}  // namespace
}  // namespace rbc
