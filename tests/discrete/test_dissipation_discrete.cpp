// SPDX-License-Identifier: GPL-3.0-or-later
// Link dashpots (discrete/link_dashpot.hpp): finite-difference gradient and Hessian with
// second-order error decay on a perturbed mesh, rigid-motion invariance, the zero at x_n.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "discrete/link_dashpot.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

struct DashpotCase {
  TriMesh mesh = testing::sphere_mesh(2, 1.0);
  Positions xn, x;
  LinkDashpotParameters p;
  Eigen::VectorXd lprev;
  DashpotCase() {
    xn = mesh.x;
    testing::perturb(xn, 0.03, 5);
    x = xn;
    testing::perturb(x, 0.05, 6);
    p.gamma_pN_s_per_um = 1.7;
    p.dt_s = 2e-3;
    lprev = link_lengths(xn, mesh.topo);
  }
  double energy(const Eigen::VectorXd& v, Eigen::VectorXd* g = nullptr) const {
    const Positions y = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, x.cols());
    Positions gp = Positions::Zero(3, x.cols());
    const double e = link_dashpot_energy(p, mesh.topo, lprev, y, g ? &gp : nullptr);
    if (g) *g = flat(gp);
    return e;
  }
};

TEST(LinkDashpot, GradientMatchesFiniteDifferencesAtSecondOrder) {
  DashpotCase c;
  Eigen::VectorXd g;
  c.energy(flat(c.x), &g);
  const auto f = [&](const Eigen::VectorXd& v) { return c.energy(v); };
  const auto [e1, e2] = testing::fd_directional_errors(f, flat(c.x), g, 1e-2, 3);
  EXPECT_GT(e1 / e2, 3.0);
  EXPECT_LT(e1 / e2, 5.0);
  const double h = std::cbrt(std::numeric_limits<double>::epsilon());
  EXPECT_LT(testing::fd_gradient_error(f, flat(c.x), g, h, 60, 4), 1e-6 * g.cwiseAbs().maxCoeff());
}

TEST(LinkDashpot, LinkHessianMatchesFiniteDifferencesAtSecondOrder) {
  const Eigen::Vector3d a(0.1, -0.2, 0.05), b(0.9, 0.3, -0.4), d(0.3, -0.7, 0.6);
  const double c = 850.0, lprev = 1.3;  // pN/um, um (link shorter than before: (L - L^n) < 0)
  Eigen::Vector3d g;
  Eigen::Matrix3d hs;
  link_dashpot_energy(c, lprev, a, b, &g, &hs);
  auto grad = [&](double h) {
    Eigen::Vector3d gp;
    link_dashpot_energy(c, lprev, a, b + h * d, &gp);
    return gp;
  };
  auto err = [&](double h) { return ((grad(h) - grad(-h)) / (2 * h) - hs * d).norm(); };
  EXPECT_GT(err(1e-2) / err(5e-3), 3.0);
  EXPECT_LT(err(1e-2) / err(5e-3), 5.0);
  EXPECT_LT(err(1e-5), 1e-6 * hs.norm());
}

TEST(LinkDashpot, ZeroAtPreviousStepAndInvariantUnderFiniteRigidMotion) {
  DashpotCase c;
  EXPECT_EQ(c.energy(flat(c.xn)), 0.0);
  const Eigen::Matrix3d rot =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
  Positions moved = rot * c.xn;
  moved.colwise() += Eigen::Vector3d(3.0, -1.0, 2.0);
  EXPECT_LT(c.energy(flat(moved)), 1e-18 * c.energy(flat(c.x)) + 1e-20);
  // Rotating the current state rigidly leaves the cost unchanged.
  Positions xr = rot * c.x;
  EXPECT_NEAR(c.energy(flat(xr)), c.energy(flat(c.x)), 1e-11 * c.energy(flat(c.x)));
}

TEST(LinkDashpot, ValidateNamesTheValue) {
  LinkDashpotParameters p;
  p.dt_s = 0.0;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p.dt_s = 1e-3;
  p.gamma_pN_s_per_um = -1.0;
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
