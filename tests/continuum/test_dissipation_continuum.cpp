// SPDX-License-Identifier: GPL-3.0-or-later
// Membrane viscosity (continuum/membrane_viscosity.hpp): finite-difference gradient and
// Hessian with second-order decay on a perturbed mesh, rigid-motion invariance, and the
// closed-form dissipation of a homogeneous rate of deformation.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "continuum/membrane_viscosity.hpp"
#include "fixtures.hpp"
#include "hessian_check.hpp"

namespace rbc {
namespace {

struct ViscosityCase {
  TriMesh mesh = testing::sphere_mesh(2, 1.0);
  Positions xn, x;
  MembraneViscosity p;
  std::vector<MembraneReference> prev;
  ViscosityCase() {
    xn = mesh.x;
    testing::perturb(xn, 0.03, 15);
    x = xn;
    testing::perturb(x, 0.05, 16);
    p.shear_pN_s_per_um = 0.7;
    p.dilatational_pN_s_per_um = 1.9;
    p.dt_s = 2e-3;
    prev = viscous_references(xn, mesh.topo);
  }
  double energy(const Eigen::VectorXd& v, Eigen::VectorXd* g = nullptr) const {
    const Positions y = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, x.cols());
    Positions gp = Positions::Zero(3, x.cols());
    const double e = membrane_viscosity_energy(p, mesh.topo, prev, y, g ? &gp : nullptr);
    if (g) *g = flat(gp);
    return e;
  }
};

TEST(MembraneViscosity, GradientMatchesFiniteDifferencesAtSecondOrder) {
  ViscosityCase c;
  Eigen::VectorXd g;
  c.energy(flat(c.x), &g);
  const auto f = [&](const Eigen::VectorXd& v) { return c.energy(v); };
  const auto [e1, e2] = testing::fd_directional_errors(f, flat(c.x), g, 1e-2, 3);
  EXPECT_GT(e1 / e2, 3.0);
  EXPECT_LT(e1 / e2, 5.0);
  const double h = std::cbrt(std::numeric_limits<double>::epsilon());
  EXPECT_LT(testing::fd_gradient_error(f, flat(c.x), g, h, 60, 4), 1e-6 * g.cwiseAbs().maxCoeff());
}

TEST(MembraneViscosity, HessianMatchesFiniteDifferencesAtSecondOrder) {
  ViscosityCase c;
  BlockHessian h(c.mesh.topo);
  h.set_zero();
  add_membrane_viscosity_hessian(c.p, c.mesh.topo, c.prev, c.x, h);
  const Eigen::SparseMatrix<double> hm = h.matrix();
  const auto grad = [&](const Eigen::VectorXd& v) {
    Eigen::VectorXd g;
    c.energy(v, &g);
    return g;
  };
  const auto hv = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return hm * d; };
  testing::expect_hessian_ok(testing::check_hessian_direction(grad, flat(c.x), hv, 1.0, 8),
                             "membrane viscosity");
}

TEST(MembraneViscosity, ZeroAtPreviousStepAndInvariantUnderFiniteRigidMotion) {
  ViscosityCase c;
  EXPECT_NEAR(c.energy(flat(c.xn)), 0.0, 1e-12 * c.energy(flat(c.x)));
  const Eigen::Matrix3d rot =
      Eigen::AngleAxisd(2.0, Eigen::Vector3d(-1, 0.3, 0.8).normalized()).toRotationMatrix();
  Positions moved = rot * c.xn;
  moved.colwise() += Eigen::Vector3d(1.0, 2.0, -3.0);
  EXPECT_LT(c.energy(flat(moved)), 1e-10 * c.energy(flat(c.x)));
  Positions xr = rot * c.x;
  EXPECT_NEAR(c.energy(flat(xr)), c.energy(flat(c.x)), 1e-11 * c.energy(flat(c.x)));
}

TEST(MembraneViscosity, HomogeneousRateGivesTheClosedFormDissipation) {
  // Flat triangle, velocity gradient L = D (symmetric), x = (I + dt D) x_n: to first order
  // in dt the term is dt R = dt A [eta_m |dev D|^2 + eta_d/2 (tr D)^2].
  MembraneViscosity p;
  p.shear_pN_s_per_um = 0.7;
  p.dilatational_pN_s_per_um = 1.9;
  const Vec3 a(0, 0, 0), b(1.2, 0.1, 0), c(0.3, 0.9, 0);
  const MembraneReference ref = make_membrane_reference(a, b, c);
  Eigen::Matrix3d d = Eigen::Matrix3d::Zero();
  d.topLeftCorner<2, 2>() << 0.8, 0.3, 0.3, -0.2;  // 1/s
  const Eigen::Matrix2d d2 = d.topLeftCorner<2, 2>();
  const Eigen::Matrix2d dev = d2 - 0.5 * d2.trace() * Eigen::Matrix2d::Identity();
  const double rate = ref.area_um2 * (p.shear_pN_s_per_um * dev.squaredNorm() +
                                      0.5 * p.dilatational_pN_s_per_um * d2.trace() * d2.trace());
  for (double dt : {1e-3, 1e-4}) {
    p.dt_s = dt;
    const Eigen::Matrix3d m = Eigen::Matrix3d::Identity() + dt * d;
    const double e = membrane_viscosity_element(p, ref, m * a, m * b, m * c);
    EXPECT_NEAR(e / (dt * rate), 1.0, 2.0 * dt * 1.0) << dt;  // O(dt) nonlinearity
  }
}

}  // namespace
}  // namespace rbc
