// SPDX-License-Identifier: GPL-3.0-or-later
// The discrete stretch on the mirror-symmetric states (StretchOptions::symmetry,
// core/mirror_symmetry.hpp) against the full problem: the same equilibria within the effect of
// the force tolerance at every force, with the Newton preconditioner and with plain L-BFGS;
// the reported residual is the full problem's; a mesh without a mirror is the old computation
// bit for bit; and a soft network whose symmetric state is a saddle (it buckles) is caught by
// the sector check and solved in full.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <utility>

#include "core/geometry.hpp"
#include "core/rest_shape.hpp"
#include "discrete/stretch.hpp"
#include "discrete/tweezers.hpp"

namespace rbc {
namespace {

TriMesh rest_mesh(int vertices, TriangulationOrientation orientation = {}) {
  RestShapeOptions o;
  o.target_vertices = vertices;
  o.orientation = orientation;
  return make_rest_shape(o);
}

Network network(const TriMesh& mesh, const WlcParameters& wlc = {}, bool level_patch = false) {
  NetworkParameters p;
  p.wlc = wlc;
  p.tweezers.keep_equal_x_together = level_patch;
  return build_network(mesh, p);
}

StretchOptions mirror_options(bool check = true) {
  StretchOptions o;
  o.symmetry = Symmetry::mirror;
  o.symmetry_check = check;
  return o;
}

/// The order of the mirror group the stretch of `net` is reduced by.
int scene_order(const Network& net) {
  return tweezers_scene_symmetry(net.rest, net.topo, net.patch).order();
}

/// Both runs converged to equilibria of the same scene, each with its largest net vertex force
/// below tol. The softest shape change of the cell has a curvature of lambda ~ 18/N pN/um per
/// um^2 of displacement (the smallest eigenvalue of the non-trivial sectors at 0 pN, measured:
/// 0.07 at N = 252, 0.018 at N = 1,002); a residual of tol per vertex in no particular
/// direction moves the state along it by ~tol/lambda, spread over N vertices: tol/(lambda
/// sqrt N) per vertex, ~1.8e-3 um at N = 1,000 and 1e-3 pN (plain L-BFGS measured 1.7e-3 um
/// from the 1e-5 pN answer in D_T at 88 pN). Two such states differ by up to twice that, and
/// their energies by the residual's work over it, N tol dx. At 0 pN a rigid turn about z costs
/// nothing and moves the extents of the (not exactly round) mesh: 10 times looser there.
void expect_same(const std::vector<StretchPoint>& full, const std::vector<StretchPoint>& reduced,
                 const Network& net, double tol_pN) {
  ASSERT_EQ(full.size(), reduced.size());
  const double n = net.topo.num_vertices;
  const double lambda_pN_per_um = 18.0 / n;
  const double dx_um = 2.0 * tol_pN / (lambda_pN_per_um * std::sqrt(n));
  for (size_t i = 0; i < full.size(); ++i) {
    const StretchPoint &a = full[i], &b = reduced[i];
    const double f = a.force_pN;
    ASSERT_TRUE(a.converged) << f << " pN: " << to_string(a.status);
    ASSERT_TRUE(b.converged) << f << " pN: " << to_string(b.status);
    const double dx = (f == 0.0 ? 10.0 : 1.0) * dx_um;
    EXPECT_NEAR(b.axial_um, a.axial_um, dx) << f << " pN";
    EXPECT_NEAR(b.transverse_um, a.transverse_um, dx) << f << " pN";
    EXPECT_NEAR(b.energy_pNum, a.energy_pNum, n * tol_pN * dx) << f << " pN";
    // The full problem's largest net vertex force, evaluated at the expanded state.
    EXPECT_LE(b.residual_pN, tol_pN) << f << " pN";
    EXPECT_LT(std::abs(b.area_drift), net.constraints.tolerance);
    EXPECT_LT(std::abs(b.volume_drift), net.constraints.tolerance);
  }
}

TEST(DiscreteSymmetry, ReducedPreconditionerInvertsTheReducedNewtonMatrix) {
  // On x = P q the preconditioner is (P'HP + P'U K U'P)^-1: H the network Hessian it
  // assembled, U = [dA/dx, dV/dx], K = s diag(k_A, k_V). Checked against the dense matrix
  // built from its definition, at a symmetric state under load (the rest shape scaled by 1.02:
  // area and volume off, so the constraint tension and pressure are not zero).
  const Network net = network(rest_mesh(250));
  auto red = std::make_shared<const SymmetryReduction>(
      make_symmetry_reduction(tweezers_scene_symmetry(net.rest, net.topo, net.patch)));
  ASSERT_EQ(red->group_order, 4);
  const Positions x = 1.02 * net.rest;
  const ConstraintMultipliers lambda{3.0, -1.5};
  const double scale = 10.0;
  // The algebra is checked on the double solves; the default single-precision ones (below)
  // solve a matrix within float rounding of it.
  NewtonPreconditionerOptions exact;
  exact.solve_precision = SolvePrecision::double_precision;
  NewtonPreconditioner pre(net, exact, red);
  ASSERT_TRUE(pre.refresh(x, lambda, scale));
  EXPECT_EQ(pre.statistics().unknowns, red->reduced_size);
  EXPECT_LT(4 * red->reduced_size, 3 * net.topo.num_vertices + 40);  // ~|G| times fewer
  const Eigen::SparseMatrix<double> hs = pre.hessian().matrix().selfadjointView<Eigen::Lower>();
  const Eigen::MatrixXd h(hs);
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(red->full_size, red->reduced_size);
  for (int i = 0; i < red->full_size; ++i)
    if (red->reduced_index[i] >= 0) p(i, red->reduced_index[i]) = red->sign[i];
  const int n = net.topo.num_vertices;
  Positions ga = Positions::Zero(3, n), gv = Positions::Zero(3, n);
  for (int f = 0; f < net.topo.num_faces(); ++f) {
    const auto t = net.topo.faces.col(f);
    Eigen::Matrix3d a, v;
    triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)), &a);
    tetra_volume(x.col(t(0)), x.col(t(1)), x.col(t(2)), &v);
    for (int k = 0; k < 3; ++k) {
      ga.col(t(k)) += a.col(k);
      gv.col(t(k)) += v.col(k);
    }
  }
  Eigen::MatrixXd u(3 * n, 2);
  u.col(0) = flat(ga);
  u.col(1) = flat(gv);
  const Eigen::Vector2d k(scale * net.constraints.area_stiffness_pN_per_um3,
                          scale * net.constraints.volume_stiffness_pN_per_um5);
  const Eigen::MatrixXd m = p.transpose() * (h + u * k.asDiagonal() * u.transpose()) * p;
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Eigen::VectorXd v(red->reduced_size);
  for (auto& e : v) e = normal(rng);
  Eigen::VectorXd w = v;
  pre.apply(w);
  EXPECT_LT((m * w - v).norm(), 1e-9 * v.norm());
  // m's condition number is 7.8e3 here, so float rounding (6e-8) allows ~5e-4. Measured: the
  // double factor rounded to float and solved in float, 8e-7 from the double solve (residual
  // 4e-6); the default, factorised in float too, 1.2e-5.
  NewtonPreconditionerOptions rounded;
  rounded.solve_precision = SolvePrecision::single_precision;
  for (const auto& [options, bound] :
       {std::pair{rounded, 1e-5}, std::pair{NewtonPreconditionerOptions{}, 1e-4}}) {
    NewtonPreconditioner single(net, options, red);
    ASSERT_TRUE(single.refresh(x, lambda, scale));
    Eigen::VectorXd ws = v;
    single.apply(ws);
    EXPECT_LT((ws - w).norm(), bound * w.norm());
    EXPECT_GT((ws - w).norm(), 1e-12 * w.norm());  // float, not the double solve
    EXPECT_LT((m * ws - v).norm(), 1e-4 * v.norm());
  }
}

TEST(DiscreteSymmetry, MirrorReducedStretchEqualsTheFullOne) {
  // N ~ 1,000: the bead patch keeps all four mirrors of the mesh; N = 500: its edge splits a
  // y -> -y pair, two are left (the inversion and the identity).
  for (const auto& [vertices, order] : {std::pair{1000, 4}, std::pair{500, 2}}) {
    const Network net = network(rest_mesh(vertices));
    ASSERT_EQ(scene_order(net), order) << vertices;
    const std::vector<double> forces{0.0, 38.0, 88.0, 193.0};
    const auto full = run_stretch(net, forces, StretchOptions{});
    const auto reduced = run_stretch(net, forces, mirror_options());
    expect_same(full, reduced, net, StretchOptions{}.minimiser.force_tolerance);
    for (const auto& p : reduced) {
      EXPECT_EQ(p.symmetry_order, order) << p.force_pN << " pN";
      EXPECT_FALSE(p.symmetry_broken) << p.force_pN << " pN";
      EXPECT_GE(p.factorisations, 1);  // preconditioned on P'HP
      // The shape is symmetric: its centre stays at the origin (inversion).
      EXPECT_LT(p.x.rowwise().mean().norm(), 1e-9);
    }
    for (const auto& p : full) EXPECT_EQ(p.symmetry_order, 1);
  }
}

TEST(DiscreteSymmetry, LevelPatchMeetsItsTargetAndKeepsEveryMirrorOfTheMirrorPlanesMesh) {
  // The mirror-planes triangulation keeps the three coordinate mirrors (order 8) at odd and
  // even icosphere frequencies (5, 7, 10, 16). Cut by x levels with a fractional edge level, the
  // patch keeps all eight and meets its area (or vertex count) target exactly; at 2,562
  // vertices the edge level's rounding once let the cut run on through levels of ~1e-16 weight.
  for (int vertices : {252, 492, 1002, 2562}) {
    const TriMesh mesh = rest_mesh(vertices, TriangulationOrientation::mirror_planes);
    ASSERT_EQ(find_mirror_symmetry(mesh.x, mesh.topo).order(), 8) << vertices;
    const double total_um2 = vertex_areas(mesh.x, mesh.topo).sum();
    for (PatchRule rule : {PatchRule::by_area, PatchRule::by_vertex_count}) {
      TweezersParameters tp;
      tp.rule = rule;
      tp.keep_equal_x_together = true;
      const TweezerPatch level = select_tweezer_patch(mesh.x, mesh.topo, tp);
      EXPECT_EQ(tweezers_scene_symmetry(mesh.x, mesh.topo, level).order(), 8) << vertices;
      double plus = 0, minus = 0;
      for (size_t k = 0; k < level.vertex.size(); ++k) {
        (level.share[k] > 0 ? plus : minus) += level.share[k];
        EXPECT_LE(std::abs(level.share[k]), 1.0);
      }
      EXPECT_NEAR(plus, 1.0, 1e-12);
      EXPECT_NEAR(minus, -1.0, 1e-12);
      // Each side is a cap x >= x_c (x <= -x_c) whose vertices carry full weight except one
      // level, the edge one: no vertex with a vanishing share, the sides mirror images.
      const Eigen::VectorXd a = vertex_areas(mesh.x, mesh.topo);
      for (double sign : {1.0, -1.0}) {
        std::vector<int> side;
        for (size_t k = 0; k < level.vertex.size(); ++k)
          if (level.share[k] * sign > 0) side.push_back(static_cast<int>(k));
        double largest = 0, lowest_x = 1e9;
        for (int k : side) {
          const double w = rule == PatchRule::by_area
                               ? std::abs(level.share[k]) / a(level.vertex[k])
                               : std::abs(level.share[k]);
          largest = std::max(largest, w);
          lowest_x = std::min(lowest_x, sign * mesh.x(0, level.vertex[k]));
        }
        std::vector<double> partial_x;
        for (int k : side) {
          const double w = rule == PatchRule::by_area
                               ? std::abs(level.share[k]) / a(level.vertex[k])
                               : std::abs(level.share[k]);
          EXPECT_GT(w, 1e-6 * largest) << vertices << ": a vertex with a vanishing share";
          if (w < largest * (1 - 1e-9)) partial_x.push_back(sign * mesh.x(0, level.vertex[k]));
        }
        for (double x : partial_x) EXPECT_NEAR(x, lowest_x, 1e-8) << "partial share off the edge";
        int outside = 0;  // vertices beyond the cap's edge left out of the patch
        for (int v = 0; v < mesh.topo.num_vertices; ++v)
          if (sign * mesh.x(0, v) > lowest_x + 1e-8 &&
              std::find(level.vertex.begin(), level.vertex.end(), v) == level.vertex.end())
            ++outside;
        EXPECT_EQ(outside, 0) << vertices;
      }
      EXPECT_EQ(
          2 * std::count_if(level.share.begin(), level.share.end(), [](double s) { return s > 0; }),
          static_cast<long>(level.vertex.size()));
      if (rule == PatchRule::by_area) {
        EXPECT_NEAR(level.area_plus_um2, tp.contact_fraction * total_um2, 1e-12 * total_um2);
        EXPECT_NEAR(level.area_minus_um2, tp.contact_fraction * total_um2, 1e-12 * total_um2);
      } else {  // whole vertices share 1/count, the edge level's less: count is the target
        double largest = 0;
        for (double s : level.share) largest = std::max(largest, std::abs(s));
        EXPECT_NEAR(1.0 / largest,
                    static_cast<double>(std::lround(tp.contact_fraction * mesh.topo.num_vertices)),
                    1e-9);
      }
    }
  }
  // Off (the default), the default mesh's patch is cut vertex by vertex as before: within half
  // a vertex's area of the target.
  const TriMesh mesh = rest_mesh(1000);
  const TweezerPatch p = select_tweezer_patch(mesh.x, mesh.topo, TweezersParameters{});
  const Eigen::VectorXd a = vertex_areas(mesh.x, mesh.topo);
  EXPECT_LT(std::abs(p.area_plus_um2 - 0.05 * a.sum()), 0.5 * a.maxCoeff());
  for (size_t k = 0; k < p.vertex.size(); ++k)
    EXPECT_NEAR(std::abs(p.share[k]), a(p.vertex[k]) / p.area_plus_um2, 1e-15);
}

TEST(DiscreteSymmetry, MirrorReducedStretchOnTheMirrorPlanesMeshEqualsTheFullOne) {
  // One eighth of the cell: the same equilibria as the full problem on the same mesh and patch.
  const Network net =
      network(rest_mesh(1000, TriangulationOrientation::mirror_planes), WlcParameters{}, true);
  ASSERT_EQ(scene_order(net), 8);
  const std::vector<double> forces{0.0, 88.0, 193.0};
  const auto full = run_stretch(net, forces, StretchOptions{});
  const auto reduced = run_stretch(net, forces, mirror_options());
  expect_same(full, reduced, net, StretchOptions{}.minimiser.force_tolerance);
  for (const auto& p : reduced) {
    EXPECT_EQ(p.symmetry_order, 8) << p.force_pN << " pN";
    EXPECT_FALSE(p.symmetry_broken) << p.force_pN << " pN";
    // Symmetric under each coordinate mirror: the centre at the origin.
    EXPECT_LT(p.x.rowwise().mean().norm(), 1e-9);
  }
}

TEST(DiscreteSymmetry, PlainLbfgsOnTheSymmetricStatesEqualsTheFullOne) {
  // Without the preconditioner (small networks above small_network_max_force_pN): L-BFGS on
  // q, its tolerance and step cap measured on full vertices.
  const Network net = network(rest_mesh(1000));
  StretchOptions plain;
  plain.precondition_min_vertices = std::numeric_limits<int>::max();
  StretchOptions plain_mirror = plain;
  plain_mirror.symmetry = Symmetry::mirror;
  const auto full = run_stretch(net, {88.0}, plain);
  const auto reduced = run_stretch(net, {88.0}, plain_mirror);
  expect_same(full, reduced, net, plain.minimiser.force_tolerance);
  EXPECT_EQ(reduced[0].factorisations, 0);
  EXPECT_EQ(reduced[0].symmetry_order, 4);
}

TEST(DiscreteSymmetry, MeshWithoutAMirrorIsTheFullComputation) {
  TriMesh mesh = rest_mesh(500);
  mesh.x(2, 7) += 1e-6;  // 100 x the mirror tolerance
  const Network net = network(mesh);
  EXPECT_EQ(scene_order(net), 1);
  const std::vector<double> forces{0.0, 88.0};
  const auto a = run_stretch(net, forces, StretchOptions{});
  const auto b = run_stretch(net, forces, mirror_options());
  for (size_t k = 0; k < forces.size(); ++k) {  // the same computation, bit for bit
    EXPECT_EQ(a[k].axial_um, b[k].axial_um);
    EXPECT_EQ(a[k].transverse_um, b[k].transverse_um);
    EXPECT_EQ(a[k].energy_pNum, b[k].energy_pNum);
    EXPECT_EQ(a[k].residual_pN, b[k].residual_pN);
    EXPECT_EQ(a[k].iterations, b[k].iterations);
    EXPECT_EQ(a[k].factorisations, b[k].factorisations);
    EXPECT_TRUE(a[k].x == b[k].x);
    EXPECT_EQ(b[k].symmetry_order, 1);
    EXPECT_FALSE(b[k].symmetry_broken);
  }
}

TEST(DiscreteSymmetry, BucklingSoftNetworkIsCaughtAndSolvedInFull) {
  // The soft corner of the calibration's prior (p 25 nm, Lmax 364 nm) on a coarse network
  // (N = 252): between 38 and 67.6 pN the stretched cell buckles. The symmetric state is then
  // a saddle: its sectors of y -> -y odd states have a curvature of -1.2 pN/um per um^2
  // (67.6 pN) and -0.5 (151 pN), against +0.1 and more for every shape change at 38 pN. The
  // full solve follows the buckled branch, below the saddle in energy.
  WlcParameters w;
  w.persistence_um = 0.025;
  w.lmax_um = 0.364;
  const Network net = network(rest_mesh(250), w);
  ASSERT_EQ(scene_order(net), 4);
  const std::vector<double> forces{0.0, 38.0, 67.6, 151.0};
  const auto full = run_stretch(net, forces, StretchOptions{});
  const auto checked = run_stretch(net, forces, mirror_options(true));
  const auto trusted = run_stretch(net, forces, mirror_options(false));
  const double tol = StretchOptions{}.minimiser.force_tolerance;
  for (size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(full[k].converged) << forces[k];
    ASSERT_TRUE(checked[k].converged) << forces[k];
    ASSERT_TRUE(trusted[k].converged) << forces[k];
  }
  // Before the buckling: symmetric, the full solve's state within the tolerance's effect.
  for (size_t k : {size_t{0}, size_t{1}}) {
    EXPECT_FALSE(checked[k].symmetry_broken) << forces[k];
    EXPECT_EQ(checked[k].symmetry_order, 4);
  }
  expect_same({full[1]}, {checked[1]}, net, tol);
  // After it: the check finds the saddle; the full solve from the pushed state reaches a
  // buckled minimum. Past a bifurcation several buckled minima exist (the push and the full
  // continuation's round-off may pick different ones), so the checked answer is compared with
  // the full one to 0.5 %, and both lie below the saddle the unchecked symmetric solve
  // reports by more than the tolerance's effect (N tol dx ~ 5e-4 pN um).
  for (size_t k : {size_t{2}, size_t{3}}) {
    EXPECT_TRUE(checked[k].symmetry_broken) << forces[k];
    EXPECT_EQ(checked[k].symmetry_order, 1);
    EXPECT_LE(checked[k].residual_pN, tol);
    EXPECT_NEAR(checked[k].axial_um, full[k].axial_um, 5e-3 * full[k].axial_um) << forces[k];
    EXPECT_NEAR(checked[k].transverse_um, full[k].transverse_um, 5e-3 * full[k].transverse_um);
    EXPECT_LT(checked[k].energy_pNum, trusted[k].energy_pNum - 0.01) << forces[k];
    EXPECT_LT(full[k].energy_pNum, trusted[k].energy_pNum - 0.01) << forces[k];
    EXPECT_FALSE(trusted[k].symmetry_broken);
    EXPECT_EQ(trusted[k].symmetry_order, 4);
  }
  // The saddle's axial diameter is off by more than the Mills error bars' resolution.
  EXPECT_GT(std::abs(trusted[2].axial_um - full[2].axial_um), 0.03);
}

}  // namespace
}  // namespace rbc
