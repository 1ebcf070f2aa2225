// SPDX-License-Identifier: GPL-3.0-or-later
// The stretch preconditioner's Hessian (discrete/network_hessian.hpp, element_hessian.hpp):
// finite-difference checks of every second derivative (STYLE.md 2), the semidefinite
// projection, and agreement of preconditioned and plain L-BFGS equilibria.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "core/geometry.hpp"
#include "core/rest_shape.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/network_hessian.hpp"
#include "discrete/stretch.hpp"
#include "discrete_cell_fixture.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

using GradFn = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;

// Central difference of the gradient along a random unit direction d against H d, at h
// and h/2: returns both errors (relative to |H d|); their ratio is ~4 at second order.
std::pair<double, double> hessian_fd_errors(const GradFn& grad, const Eigen::VectorXd& x,
                                            const Eigen::VectorXd& hd_of_unit_dir,
                                            const Eigen::VectorXd& dir, double h) {
  auto err = [&](double step) {
    const Eigen::VectorXd fd = (grad(x + step * dir) - grad(x - step * dir)) / (2 * step);
    return (fd - hd_of_unit_dir).norm() / hd_of_unit_dir.norm();
  };
  return {err(h), err(h / 2)};
}

Eigen::VectorXd random_unit(Eigen::Index n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::VectorXd d(n);
  for (Eigen::Index i = 0; i < n; ++i) d(i) = g(rng);
  return d / d.norm();
}

void expect_second_order(std::pair<double, double> e, double tol, const char* what) {
  EXPECT_GT(e.first / e.second, 3.0) << what << ": errors " << e.first << ", " << e.second;
  EXPECT_LT(e.second, tol) << what;
}

// A randomly perturbed triangle / hinge (no symmetric point where derivatives vanish).
Eigen::Matrix<double, 3, 4> random_points(unsigned seed) {
  Eigen::Matrix<double, 3, 4> p;
  p << 0.0, 1.0, 0.4, 0.6, 0.0, 0.1, 0.9, -0.8, 0.0, 0.05, 0.2, 0.3;
  Positions q = p;
  testing::perturb(q, 0.1, seed);
  return q;
}

TEST(ElementHessian, TriangleAreaMatchesFiniteDifferences) {
  const auto p = random_points(3);
  Eigen::VectorXd x(9);
  for (int k = 0; k < 3; ++k) x.segment<3>(3 * k) = p.col(k);
  const GradFn grad = [](const Eigen::VectorXd& v) {
    Eigen::Matrix3d g;
    triangle_area(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), &g);
    return Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(g.data(), 9));
  };
  Matrix9d h;
  triangle_area_hessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), nullptr, &h);
  EXPECT_LT((h - h.transpose()).norm(), 1e-14 * h.norm());
  const Eigen::VectorXd d = random_unit(9, 4);
  expect_second_order(hessian_fd_errors(grad, x, h * d, d, 1e-2), 1e-4, "area Hessian");
  // Rigid translations are in the null space.
  Eigen::VectorXd t(9);
  for (int k = 0; k < 3; ++k) t.segment<3>(3 * k) = Eigen::Vector3d(0.3, -0.2, 0.7);
  EXPECT_LT((h * t).norm(), 1e-12 * h.norm());
}

TEST(ElementHessian, TetraVolumeMatchesFiniteDifferences) {
  const auto p = random_points(5);
  Eigen::VectorXd x(9);
  for (int k = 0; k < 3; ++k) x.segment<3>(3 * k) = p.col(k) + Eigen::Vector3d(0.5, 0.2, 1.0);
  const GradFn grad = [](const Eigen::VectorXd& v) {
    Eigen::Matrix3d g;
    tetra_volume(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), &g);
    return Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(g.data(), 9));
  };
  const Matrix9d h = tetra_volume_hessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6));
  const Eigen::VectorXd d = random_unit(9, 6);
  // V is cubic: the central difference of its (quadratic) gradient is exact up to round-off.
  const auto e = hessian_fd_errors(grad, x, h * d, d, 1e-2);
  EXPECT_LT(e.first, 1e-10);
  EXPECT_LT((h - h.transpose()).norm(), 1e-15);
}

TEST(ElementHessian, HingeLengthAngleMatchesFiniteDifferences) {
  const auto p = random_points(7);
  Eigen::VectorXd x(12);
  for (int k = 0; k < 4; ++k) x.segment<3>(3 * k) = p.col(k);
  const GradFn grad = [](const Eigen::VectorXd& v) {
    Eigen::Matrix<double, 3, 4> g;  // q = L theta through the discrete/ kernel's gradient
    Positions pts = Eigen::Map<const Eigen::Matrix<double, 3, 4>>(v.data());
    Topology topo;  // the hinge kernel needs only edges and edge_opposite
    topo.num_vertices = 4;
    topo.edges.resize(2, 1);
    topo.edges << 0, 1;
    topo.edge_opposite.resize(2, 1);
    topo.edge_opposite << 2, 3;
    hinge_length_angle(pts, topo, 0, &g);
    return Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(g.data(), 12));
  };
  Eigen::Matrix<double, 3, 4> g;
  Matrix12d h;
  hinge_length_angle_hessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9), &g,
                             &h);
  EXPECT_LT((Eigen::Map<Eigen::VectorXd>(g.data(), 12) - grad(x)).norm(), 1e-13);
  const Eigen::VectorXd d = random_unit(12, 8);
  expect_second_order(hessian_fd_errors(grad, x, h * d, d, 1e-2), 1e-4, "hinge Hessian");
}

TEST(ElementHessian, ProjectionIsSemidefiniteAndKeepsPositiveMatrices) {
  Eigen::Matrix<double, 9, 9> a = Eigen::Matrix<double, 9, 9>::Random();
  a = (a + a.transpose()).eval();
  Eigen::Matrix<double, 9, 9> p = a;
  project_positive_semidefinite<9>(p);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> es(p);
  EXPECT_GT(es.eigenvalues().minCoeff(), -1e-12);
  // The projection is the nearest semidefinite matrix: A - P is negative semidefinite.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> diff(a - p);
  EXPECT_LT(diff.eigenvalues().maxCoeff(), 1e-12);
  Eigen::Matrix<double, 9, 9> spd = a * a.transpose();
  Eigen::Matrix<double, 9, 9> q = spd;
  project_positive_semidefinite<9>(q);
  EXPECT_LT((q - spd).norm(), 1e-12 * spd.norm());
}

// A perturbed cell under load with nonzero multipliers (every Hessian term active).
struct LoadedCell : testing::SmallCell {
  LoadedCell() : testing::SmallCell(NetworkParameters{}, 17, 2.0) {}
  ConstraintCurvature curvature() const {
    const double a = total_area(x, net.topo), v = enclosed_volume(x, net.topo);
    return {load.multipliers.area_pN_per_um + load.stiffness_scale *
                                                  net.constraints.area_stiffness_pN_per_um3 *
                                                  (a - net.area0_um2),
            load.multipliers.volume_pN_per_um2 + load.stiffness_scale *
                                                     net.constraints.volume_stiffness_pN_per_um5 *
                                                     (v - net.volume0_um3)};
  }
};

TEST(NetworkHessian, UnprojectedMatrixIsTheExactHessian) {
  LoadedCell c;
  NetworkHessianOptions o;
  o.project = false;
  o.hinge_curvature = true;
  o.shift_fraction = 0.0;
  NetworkHessian nh(c.net, o);
  const Eigen::SparseMatrix<double>& h = nh.assemble(c.x, c.curvature());
  const int n = c.net.topo.num_vertices;
  // The penalties' rank-two part, which the preconditioner applies by Woodbury.
  Positions ga = Positions::Zero(3, n), gv = Positions::Zero(3, n);
  for (int f = 0; f < c.net.topo.num_faces(); ++f) {
    const auto t = c.net.topo.faces.col(f);
    Eigen::Matrix3d a, v;
    triangle_area(c.x.col(t(0)), c.x.col(t(1)), c.x.col(t(2)), &a);
    tetra_volume(c.x.col(t(0)), c.x.col(t(1)), c.x.col(t(2)), &v);
    for (int k = 0; k < 3; ++k) {
      ga.col(t(k)) += a.col(k);
      gv.col(t(k)) += v.col(k);
    }
  }
  const double ka = c.load.stiffness_scale * c.net.constraints.area_stiffness_pN_per_um3;
  const double kv = c.load.stiffness_scale * c.net.constraints.volume_stiffness_pN_per_um5;
  const GradFn grad = [&](const Eigen::VectorXd& v) {
    Positions g;
    network_energy(c.net, Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, n), c.load, &g);
    return Eigen::VectorXd(flat(g));
  };
  for (unsigned seed : {21u, 22u}) {
    const Eigen::VectorXd d = random_unit(3 * n, seed);
    const Eigen::VectorXd hd = h.selfadjointView<Eigen::Lower>() * d +
                               ka * flat(ga) * flat(ga).dot(d) + kv * flat(gv) * flat(gv).dot(d);
    // Step ~ 1e-3 x the edge length (0.3 um): the WLC's stiffening keeps higher orders large.
    expect_second_order(hessian_fd_errors(grad, flat(c.x), hd, d, 1e-3), 1e-5, "network Hessian");
  }
}

TEST(NetworkHessian, ProjectedMatrixIsPositiveDefiniteAndOneRingBoundsTwoRing) {
  LoadedCell c;
  NetworkHessianOptions o;
  o.hinge_curvature = true;
  NetworkHessian two(c.net, o);
  o.bending_coupling = BendingCoupling::one_ring;
  NetworkHessian one(c.net, o);
  const Eigen::MatrixXd h2 =
      Eigen::MatrixXd(two.assemble(c.x, c.curvature())).selfadjointView<Eigen::Lower>();
  const Eigen::MatrixXd h1 =
      Eigen::MatrixXd(one.assemble(c.x, c.curvature())).selfadjointView<Eigen::Lower>();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e2(h2, Eigen::EigenvaluesOnly);
  EXPECT_GT(e2.eigenvalues().minCoeff(), 0.0);
  // Same shift (the diagonal bound raises the mean diagonal): compare without it.
  const double s2 = 1e-4 * h2.diagonal().mean() / (1 + 1e-4);
  const double s1 = 1e-4 * h1.diagonal().mean() / (1 + 1e-4);
  Eigen::MatrixXd diff = h1 - h2;
  diff.diagonal().array() -= s1 - s2;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ed(diff, Eigen::EigenvaluesOnly);
  EXPECT_GT(ed.eigenvalues().minCoeff(), -1e-9 * e2.eigenvalues().maxCoeff())
      << "the one-ring matrix must bound the two-ring one from above";
  // Its pattern is the mesh's edges only (plus the diagonal).
  const Eigen::SparseMatrix<double>& m1 = one.matrix();
  const long blocks = m1.nonZeros() / 9;
  EXPECT_EQ(blocks, c.net.topo.num_vertices + c.net.topo.num_edges());
}

TEST(NetworkHessian, PreconditionedAndPlainSolvesAgree) {
  // The preconditioner changes the path, never the equilibrium: D_A and D_T at 88 pN from
  // both minimisers agree to 1e-4 relative. At the default force tolerance (1e-3 pN) D_T
  // (two extreme vertices) is only fixed to ~1e-4 along the soft out-of-plane modes, so
  // both solve to 1e-5 pN here.
  RestShapeOptions ro;
  ro.target_vertices = 400;
  const Network net = build_network(make_rest_shape(ro), NetworkParameters{});
  StretchOptions plain, pre;
  plain.precondition_min_vertices = std::numeric_limits<int>::max();
  pre.precondition_min_vertices = 0;
  plain.minimiser.force_tolerance = pre.minimiser.force_tolerance = 1e-5;
  Positions xp = net.rest, xq = net.rest;
  ConstraintMultipliers lp, lq;
  const StretchPoint a = solve_equilibrium(net, 88.0, xp, lp, plain);
  const StretchPoint b = solve_equilibrium(net, 88.0, xq, lq, pre);
  ASSERT_TRUE(a.converged) << a.status;
  ASSERT_TRUE(b.converged) << b.status;
  EXPECT_EQ(a.factorisations, 0);
  EXPECT_GE(b.factorisations, 1);
  EXPECT_LT(b.iterations, a.iterations / 4) << "the preconditioner should cut iterations";
  EXPECT_NEAR(b.axial_um / a.axial_um, 1.0, 1e-4);
  EXPECT_NEAR(b.transverse_um / a.transverse_um, 1.0, 1e-4);
  EXPECT_NEAR(lq.area_pN_per_um, lp.area_pN_per_um, 1e-3 * std::abs(lp.area_pN_per_um) + 1e-3);
}

}  // namespace
}  // namespace rbc
