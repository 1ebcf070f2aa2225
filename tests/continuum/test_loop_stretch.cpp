// SPDX-License-Identifier: GPL-3.0-or-later
// The continuum stretch on the Loop element (continuum/loop_terms.hpp, continuum/loop_stretch.hpp):
// each term's derivatives against finite differences, the rest state stress-free, the limit
// surface's area and volume against the sphere's closed forms, the load's total force exact, and
// the stretch against the linear element on a fine mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <string>

#include "continuum/adapted_mesh.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/hessian_check.hpp"
#include "continuum/loop_stretch.hpp"
#include "continuum/p2_law.hpp"
#include "core/mirror_symmetry.hpp"
#include "core/reduced_problem.hpp"
#include "fixtures.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc {
namespace {

std::array<Vec3, 3> loop_stretch_test_vectors(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  return {Vec3(0.5 + u(rng), u(rng), 1.0 + u(rng)), Vec3(1.0 + u(rng), u(rng), u(rng)),
          Vec3(u(rng), 0.9 + u(rng), u(rng))};
}

// FD checks of a density f(z) with analytic gradient and Hessian (z of size n).
void check_density(
    const std::function<double(const Eigen::VectorXd&, Eigen::VectorXd*, Eigen::MatrixXd*)>& f,
    const Eigen::VectorXd& z, const char* what) {
  Eigen::VectorXd g;
  Eigen::MatrixXd h;
  f(z, &g, &h);
  auto value = [&](const Eigen::VectorXd& y) { return f(y, nullptr, nullptr); };
  const auto [eh, eh2] = testing::fd_directional_errors(value, z, g, 1e-3, 4);
  EXPECT_GT(eh / eh2, 3.0) << what;
  EXPECT_LT(testing::fd_gradient_error(value, z, g, 6e-6, static_cast<int>(z.size()), 4),
            1e-7 * (1 + g.norm()))
      << what;
  const auto grad = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd gy;
    f(y, &gy, nullptr);
    return gy;
  };
  const auto hv = [&](const Eigen::VectorXd& d) { return Eigen::VectorXd(h * d); };
  testing::expect_hessian_ok(testing::check_hessian_direction(grad, z, hv, 1.0, 6), what);
  EXPECT_LT((h - h.transpose()).cwiseAbs().maxCoeff(), 1e-12 * (1 + h.cwiseAbs().maxCoeff()))
      << what;
}

// A density with fixed-size derivatives (N) as check_density's dynamic-size function.
template <int N, class F>
auto loop_dynamic_density(F f) {
  return [f](const Eigen::VectorXd& z, Eigen::VectorXd* g, Eigen::MatrixXd* h) {
    Eigen::Matrix<double, N, 1> gn;
    Eigen::Matrix<double, N, N> hn;
    const double e = f(z, g != nullptr ? &gn : nullptr, h != nullptr ? &hn : nullptr);
    if (g != nullptr) *g = gn;
    if (h != nullptr) *h = hn;
    return e;
  };
}

TEST(LoopTerms, DensityDerivativesMatchFiniteDifferences) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  for (unsigned seed : {1u, 2u}) {
    const auto v = loop_stretch_test_vectors(seed);
    const LoopMembraneReference ref =
        make_loop_membrane_reference(v[1] + Vec3(0.05, 0.1, 0.0), v[2] - Vec3(0.1, 0.0, 0.05));
    Eigen::VectorXd z6(6), z9(9);
    z6 << v[1], v[2];
    z9 << v[0], v[1], v[2];
    check_density(loop_dynamic_density<6>([&](const Eigen::VectorXd& z, auto* g, auto* h) {
                    return loop_membrane_density(law, ref, z.head<3>(), z.tail<3>(), g, h);
                  }),
                  z6, "membrane");
    check_density(loop_dynamic_density<6>([&](const Eigen::VectorXd& z, auto* g, auto* h) {
                    return loop_area_density(z.head<3>(), z.tail<3>(), g, h);
                  }),
                  z6, "area");
    check_density(loop_dynamic_density<9>([&](const Eigen::VectorXd& z, auto* g, auto* h) {
                    return loop_volume_density(z.segment<3>(0), z.segment<3>(3), z.segment<3>(6), g,
                                               h);
                  }),
                  z9, "volume");
  }
}

TEST(LoopTerms, MembraneIsStressFreeAtItsReferenceAndRigidMotionInvariant) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const auto v = loop_stretch_test_vectors(3);
  const LoopMembraneReference ref = make_loop_membrane_reference(v[1], v[2]);
  Vector6d g;
  EXPECT_NEAR(loop_membrane_density(law, ref, v[1], v[2], &g),
              ref.jacobian_um2 * law.evaluate(0, 0).psi, 1e-12);
  EXPECT_LT(g.norm(), 1e-10);
  const Eigen::Matrix3d r = testing::random_rotation(4);
  const Vec3 a = 1.1 * v[1] + 0.1 * v[2], b = 0.95 * v[2];
  EXPECT_NEAR(loop_membrane_density(law, ref, r * a, r * b), loop_membrane_density(law, ref, a, b),
              1e-12);
  EXPECT_THROW(make_loop_membrane_reference(v[1], 2.0 * v[1]), InvalidParameter);
}

LoopContinuumModel loop_test_model(int elements) {
  const EvansFungShape shape;
  TriMesh m = make_continuum_mesh(elements, shape);
  for (int i = 0; i < m.x.cols(); ++i) m.x.col(i) = evans_fung_project(shape, m.x.col(i));
  return build_loop_continuum_model(m, testing::closed_form_p2_law(), {},
                                    rest_contact_plane(shape, 0.05));
}

TEST(LoopStretch, AreaAndVolumeOfTheInterpolatedSphereConverge) {
  const double r = 2.5;
  std::vector<double> ea, ev;
  for (int freq : {4, 8, 16}) {
    const TriMesh m = testing::sphere_mesh(freq, r);
    LoopContinuumModel model;
    model.topo = m.topo;
    model.quadrature = loop_quadrature(m.topo);
    const ConstraintValues c =
        loop_constraints(model, loop_interpolating_control_points(m.topo, m.x), false);
    ea.push_back(std::abs(c.area_um2 / (4 * units::pi * r * r) - 1));
    ev.push_back(std::abs(c.volume_um3 / (4.0 / 3 * units::pi * r * r * r) - 1));
  }
  std::printf("[ sphere ] limit-surface area errors %.2e %.2e %.2e, volume %.2e %.2e %.2e\n", ea[0],
              ea[1], ea[2], ev[0], ev[1], ev[2]);
  EXPECT_LT(ea[2], 2e-5);
  EXPECT_LT(ev[2], 2e-5);
  EXPECT_GT(std::log(ea[1] / ea[2]) / std::log(2.0), 1.8);
}

TEST(LoopStretch, EachCapCarriesExactlyTheForceAndTheLoadIsMirrorSymmetric) {
  const LoopContinuumModel m = loop_test_model(1000);
  double right = 0, left = 0, other = 0;
  for (int i = 0; i < m.topo.num_vertices; ++i) {
    right += m.load_right(3 * i);
    left += m.load_left(3 * i);
    other += std::abs(m.load_right(3 * i + 1)) + std::abs(m.load_right(3 * i + 2));
  }
  EXPECT_NEAR(right, 1.0, 1e-13);
  EXPECT_NEAR(left, 1.0, 1e-13);
  EXPECT_EQ(other, 0.0);
  EXPECT_GT(m.load_points, 100);
  // A rigid translation does no work: the two caps pull equally and oppositely.
  double work = 0;
  for (int i = 0; i < m.topo.num_vertices; ++i) work += m.load(3 * i);
  EXPECT_NEAR(work, 0.0, 1e-13);
}

TEST(LoopStretch, EnergyGradientAndLagrangianHessianMatchFiniteDifferences) {
  const LoopContinuumModel m = loop_test_model(500);
  Positions x = m.rest;
  testing::perturb(x, 0.02, 8);
  const double force = 60.0, la = 3.0, lv = -2.0;
  const Eigen::Index n = x.cols();
  auto lagrangian = [&](const Eigen::VectorXd& y, Eigen::VectorXd* g) {
    const Eigen::Map<const Positions> xy(y.data(), 3, n);
    Positions ge;
    const double e = loop_continuum_energy(m, xy, force, g ? &ge : nullptr);
    const ConstraintValues c = loop_constraints(m, xy, g != nullptr);
    if (g) *g = flat(ge) + la * flat(c.grad_area) + lv * flat(c.grad_volume);
    return e + la * c.area_um2 + lv * c.volume_um3;
  };
  const Eigen::VectorXd x0 = flat(x);
  Eigen::VectorXd g0;
  lagrangian(x0, &g0);
  auto value = [&](const Eigen::VectorXd& y) { return lagrangian(y, nullptr); };
  const auto [eh, eh2] = testing::fd_directional_errors(value, x0, g0, 1e-3, 2);
  EXPECT_GT(eh / eh2, 3.0);
  EXPECT_LT(testing::fd_gradient_error(value, x0, g0, 1e-5, 30, 2), 1e-6 * (1 + g0.norm()));
  LoopHessianAssembler assembler(m);
  const Eigen::SparseMatrix<double>& h = assembler.assemble(m, x, la, lv);
  const auto grad = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd g;
    lagrangian(y, &g);
    return g;
  };
  const auto hv = [&](const Eigen::VectorXd& d) {
    return Eigen::VectorXd(h.selfadjointView<Eigen::Lower>() * d);
  };
  testing::expect_hessian_ok(testing::check_hessian_direction(grad, x0, hv, 1.0, 3),
                             "Loop Lagrangian");
}

// On a state with the scene's mirrors, one quadrature point per orbit weighted by the orbit's
// size gives the full energy and constraints and the same reduced gradients P' g and reduced
// Hessian P' H P; off the symmetric states it does not (so the comparison can fail).
TEST(LoopStretch, OrbitPointsGiveTheFullProblemOnSymmetricStates) {
  const LoopContinuumModel m = loop_test_model(500);
  const MeshSymmetry group = find_mirror_symmetry(m.rest, m.topo);
  ASSERT_EQ(group.order(), 4);  // the default icosphere's mirrors
  const LoopPointSet all = loop_all_points(m), orbits = loop_orbit_points(m, group);
  double represented = 0;
  for (double k : orbits.multiplicity) represented += k;
  EXPECT_EQ(represented, static_cast<double>(m.quadrature.size()));
  EXPECT_LT(orbits.points.size(), m.quadrature.size() / 3);
  const SymmetryReduction r = make_symmetry_reduction(group);
  Positions x = m.rest;
  testing::perturb(x, 0.03, 5);
  const Eigen::Index n = x.cols();
  const Eigen::VectorXd xs = expand(r, symmetric_part(r, flat(x)));
  const Eigen::Map<const Positions> sym(xs.data(), 3, n);
  Positions gf, go;
  ConstraintValues cf, co;
  const double ef = loop_evaluate(m, all, sym, 60.0, &gf, &cf);
  const double eo = loop_evaluate(m, orbits, sym, 60.0, &go, &co);
  EXPECT_NEAR(eo, ef, 1e-12 * std::abs(ef));
  EXPECT_NEAR(co.area_um2, cf.area_um2, 1e-12 * cf.area_um2);
  EXPECT_NEAR(co.volume_um3, cf.volume_um3, 1e-12 * cf.volume_um3);
  auto reduced_gap = [&](const Positions& a, const Positions& b) {
    const Eigen::VectorXd ra = reduce(r, Eigen::VectorXd(flat(a))),
                          rb = reduce(r, Eigen::VectorXd(flat(b)));
    return (ra - rb).cwiseAbs().maxCoeff() / rb.cwiseAbs().maxCoeff();
  };
  EXPECT_LT(reduced_gap(go, gf), 1e-11);
  EXPECT_LT(reduced_gap(co.grad_area, cf.grad_area), 1e-11);
  EXPECT_LT(reduced_gap(co.grad_volume, cf.grad_volume), 1e-11);
  LoopHessianAssembler full_h(m), orbit_h(m, orbits);
  const Eigen::SparseMatrix<double>& hf = full_h.assemble(m, sym, 3.0, -2.0);
  const Eigen::SparseMatrix<double>& ho = orbit_h.assemble(m, sym, 3.0, -2.0);
  EXPECT_LT(ho.nonZeros(), hf.nonZeros());
  ReducedMatrix map_f(r, hf), map_o(r, ho);
  const Eigen::MatrixXd rf = Eigen::MatrixXd(map_f.reduce(hf)),
                        ro = Eigen::MatrixXd(map_o.reduce(ho));
  EXPECT_LT((ro - rf).cwiseAbs().maxCoeff(), 1e-11 * rf.cwiseAbs().maxCoeff());
  // Off the symmetric states the orbit points do not stand for the rest.
  const double ea = loop_evaluate(m, orbits, x, 60.0, nullptr, nullptr);
  EXPECT_GT(std::abs(ea - loop_evaluate(m, all, x, 60.0, nullptr, nullptr)), 1e-6 * std::abs(ef));
}

// The mirror path (4 mirrors on the default icosphere, shared by the load) reaches the full
// path's equilibria, each checked stable in the other 3 sectors. (At 0 pN the turns about y and z
// are free as well as the turn about x, and the two paths end up to 3e-4 um apart in D_A along
// them: the loaded states are compared.)
TEST(LoopStretch, MirrorPathReachesTheFullPathsEquilibria) {
  const LoopContinuumModel m = loop_test_model(500);
  const std::vector<double> forces{30.6, 88.0, 193.0};
  LoopStretchOptions mirror;
  mirror.symmetry = Symmetry::mirror;
  const auto full = run_loop_stretch(m, forces);
  const auto sym = run_loop_stretch(m, forces, mirror);
  for (std::size_t k = 0; k < forces.size(); ++k) {
    ASSERT_EQ(full[k].status, NewtonStatus::converged) << forces[k];
    ASSERT_EQ(sym[k].status, NewtonStatus::converged) << forces[k];
    EXPECT_EQ(full[k].symmetry_order, 1);
    EXPECT_EQ(sym[k].symmetry_order, 4) << forces[k];
    EXPECT_EQ(sym[k].stability_factorisations, 3) << forces[k];
    EXPECT_FALSE(sym[k].symmetry_broken) << forces[k];
    EXPECT_LT(sym[k].residual_pN, 1e-5) << forces[k];
    EXPECT_NEAR(sym[k].diameters.axial_um / full[k].diameters.axial_um, 1.0, 1e-7) << forces[k];
    EXPECT_NEAR(sym[k].diameters.transverse_um / full[k].diameters.transverse_um, 1.0, 1e-7)
        << forces[k];
  }
  EXPECT_GT(sym[2].diameters.axial_um, sym[0].diameters.axial_um + 2.0);
}

// The soft corner of the calibration's prior (p 25 nm, Lmax 364 nm; the linear element's
// ContinuumSymmetry.BucklingSoftCellIsCaughtAndSolvedInFull, which buckles between 38 and
// 67.6 pN): on the Loop element the stretched cell is still symmetric at 67.6 pN and buckled at
// 151 pN, where the symmetric state is a saddle. The check finds it, and the full solve from the
// pushed state reaches the buckled branch the full path follows.
TEST(LoopStretch, BucklingSoftCellIsCaughtAndSolvedInFull) {
  const EvansFungShape shape;
  WlcParameters soft;
  soft.persistence_um = 0.025;
  soft.lmax_um = 0.364;
  TriMesh mesh = make_continuum_mesh(500, shape);
  for (int i = 0; i < mesh.x.cols(); ++i) mesh.x.col(i) = evans_fung_project(shape, mesh.x.col(i));
  const LoopContinuumModel m = build_loop_continuum_model(
      mesh, make_membrane_law(soft, StericParameters{}, WlcExpansion::full), {},
      rest_contact_plane(shape, 0.05));
  const std::vector<double> forces{0.0, 38.0, 67.6, 151.0};
  LoopStretchOptions mirror;
  mirror.symmetry = Symmetry::mirror;
  const auto full = run_loop_stretch(m, forces);
  const auto sym = run_loop_stretch(m, forces, mirror);
  const SymmetryReduction r = make_symmetry_reduction(find_mirror_symmetry(m.rest, m.topo));
  auto asymmetry = [&](const Positions& x) {
    const Eigen::VectorXd xf = flat(x);
    return (expand(r, symmetric_part(r, xf)) - xf).cwiseAbs().maxCoeff();
  };
  for (std::size_t k = 0; k < forces.size(); ++k) {
    ASSERT_EQ(full[k].status, NewtonStatus::converged) << forces[k];
    ASSERT_EQ(sym[k].status, NewtonStatus::converged) << forces[k];
  }
  for (std::size_t k : {std::size_t{1}, std::size_t{2}}) {
    EXPECT_FALSE(sym[k].symmetry_broken) << forces[k];
    EXPECT_EQ(sym[k].symmetry_order, 4) << forces[k];
    EXPECT_NEAR(sym[k].diameters.axial_um / full[k].diameters.axial_um, 1.0, 1e-6) << forces[k];
  }
  EXPECT_TRUE(sym[3].symmetry_broken);
  EXPECT_EQ(sym[3].symmetry_order, 1);
  EXPECT_GT(asymmetry(full[3].x), 1e-2);
  EXPECT_GT(asymmetry(sym[3].x), 1e-2);
  // Several buckled minima exist past a bifurcation: agreement to 0.5 %.
  EXPECT_NEAR(sym[3].diameters.axial_um / full[3].diameters.axial_um, 1.0, 5e-3);
  EXPECT_NEAR(sym[3].diameters.transverse_um / full[3].diameters.transverse_um, 1.0, 5e-3);
}

// The diameters formed from the sample points that can be extreme equal those of all the sample
// points, at rest, stretched, perturbed and turned (the extremes anywhere); the pruning rests on
// the sampling weights being >= 0 and summing to 1 in each row, checked too.
TEST(LoopStretch, DiametersFromTheSamplesThatCanBeExtremeEqualAllSamples) {
  const LoopContinuumModel m = loop_test_model(500);
  const auto& s = m.measure_sampling;
  for (Eigen::Index r = 0; r < s.outerSize(); ++r) {
    double sum = 0, smallest = 1;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(s, r); it; ++it)
      sum += it.value(), smallest = std::min(smallest, it.value());
    ASSERT_NEAR(sum, 1.0, 1e-12) << r;
    ASSERT_GE(smallest, 0.0) << r;
  }
  std::vector<Positions> states{m.rest};
  states.push_back(run_loop_stretch(m, {120.0})[0].x);
  Positions perturbed = m.rest;
  testing::perturb(perturbed, 0.05, 4);
  states.push_back(perturbed);
  const Eigen::Matrix3d turn =
      (Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized())).toRotationMatrix();
  states.push_back(turn * states[1]);
  for (std::size_t k = 0; k < states.size(); ++k) {
    const Diameters all = measure_diameters((s * states[k].transpose()).transpose());
    const Diameters pruned = loop_surface_diameters(m, states[k]);
    EXPECT_NEAR(pruned.axial_um, all.axial_um, 1e-12 * all.axial_um) << k;
    EXPECT_NEAR(pruned.transverse_um, all.transverse_um, 1e-12 * all.transverse_um) << k;
  }
}

// The Loop stretch at 88 pN on 1,000 elements against the linear element on 9,680 (full law,
// exact contact load, quadric-fit diameters): the two discretisations of one model agree.
TEST(LoopStretch, AgreesWithTheLinearElementOnAFineMesh) {
  const EvansFungShape shape;
  const IsotropicMembraneLaw law =
      make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::full);
  TriMesh m = make_continuum_mesh(1000, shape);
  for (int i = 0; i < m.x.cols(); ++i) m.x.col(i) = evans_fung_project(shape, m.x.col(i));
  const LoopContinuumModel lm =
      build_loop_continuum_model(m, law, {}, rest_contact_plane(shape, 0.05));
  const auto lp = run_loop_stretch(lm, {88.0});
  ASSERT_EQ(lp[0].status, NewtonStatus::converged);
  const ContinuumModel fine = build_continuum_model(make_continuum_mesh(9680, shape), law, {});
  ContinuumOptions co;
  co.load = ContinuumLoad::exact_contact;
  co.measure = ContinuumMeasure::quadric_fit;
  const auto fp = run_continuum_stretch(fine, {88.0}, co);
  std::printf(
      "88 pN: Loop 1,000 elements D_A %.4f D_T %.4f (%d iterations); linear 9,680: %.4f "
      "%.4f\n",
      lp[0].diameters.axial_um, lp[0].diameters.transverse_um, lp[0].iterations, fp[0].axial_um,
      fp[0].transverse_um);
  EXPECT_NEAR(lp[0].diameters.axial_um / fp[0].axial_um, 1.0, 3e-3);
  EXPECT_NEAR(lp[0].diameters.transverse_um / fp[0].transverse_um, 1.0, 3e-3);
}

// The 13 Mills forces against the spectrin-level reference (data/tradeoff/reference.csv: the
// network at 27,042 vertices, mean over 5 rotations), full law, uniform icospheres with their
// vertices on the Evans-Fung surface, 4 orientations each (RestShapeOptions::rotation_seed 0-3):
// the largest relative error of D_A and D_T over the forces, worst over the orientations. The
// linear element's best rows at these sizes (data/tradeoff/accuracy_cost_refined.csv, the same
// load and a quadric-fitted measure) err 0.575 % (760 triangles), 0.545 % (1,220) and 0.145 %
// (2,288). About 5 minutes (`ctest -L slow -R LoopStretch`).
TEST(SlowReferenceLoopStretch, ErrsAgainstTheSpectrinLevelOverFourOrientations) {
  const EvansFungShape shape;
  const IsotropicMembraneLaw law =
      make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::full);
  std::vector<double> forces, ref_a, ref_t;
  std::ifstream in(std::string(RBC_SOURCE_DIR) + "/data/tradeoff/reference.csv");
  ASSERT_TRUE(in.good());
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line[0] == 'f') continue;
    double v[4];
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf", v, v + 1, v + 2, v + 3), 4);
    forces.push_back(v[0]);
    ref_a.push_back(v[1]);
    ref_t.push_back(v[3]);
  }
  ASSERT_EQ(forces.size(), 13u);
  std::map<int, double> worst;
  for (int el : {500, 1000, 2000})
    for (unsigned seed : {0u, 1u, 2u, 3u}) {
      TriMesh m = make_continuum_mesh(el, seed);
      for (int i = 0; i < m.x.cols(); ++i) m.x.col(i) = evans_fung_project(shape, m.x.col(i));
      const LoopContinuumModel lm =
          build_loop_continuum_model(m, law, {}, rest_contact_plane(shape, 0.05));
      const auto pts = run_loop_stretch(lm, forces);
      double err = 0;
      int iterations = 0;
      for (std::size_t i = 0; i < forces.size(); ++i) {
        ASSERT_EQ(pts[i].status, NewtonStatus::converged) << forces[i] << " pN";
        iterations += pts[i].iterations;
        err = std::max({err, std::abs(pts[i].diameters.axial_um / ref_a[i] - 1),
                        std::abs(pts[i].diameters.transverse_um / ref_t[i] - 1)});
      }
      std::printf(
          "[ Loop ] %4d elements, %4d vertices, orientation %u: worst %.3f %% (%d Newton "
          "iterations)\n",
          el, static_cast<int>(m.x.cols()), seed, 100 * err, iterations);
      worst[el] = std::max(worst[el], err);
    }
  EXPECT_LT(worst[1000], 0.005);
  EXPECT_LT(worst[2000], 0.0015);
}

}  // namespace
}  // namespace rbc
