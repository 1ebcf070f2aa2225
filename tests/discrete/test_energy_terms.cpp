// SPDX-License-Identifier: GPL-3.0-or-later
// Finite-difference and invariance tests of every discrete energy term (STYLE.md 2-3).
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "core/geometry.hpp"
#include "core/rest_shape.hpp"
#include "core/units.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/network.hpp"
#include "discrete_cell_fixture.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

using testing::SmallCell;

using TermFn = std::function<double(const Positions&, Positions*)>;

// The error of the central difference must shrink at second order as h halves, and be
// small at the step h ~ cbrt(eps) x length scale.
void expect_second_order_gradient(const TermFn& term, const Positions& x, const char* what) {
  Positions g = Positions::Zero(3, x.cols());
  term(x, &g);
  const Eigen::VectorXd x0 = flat(x);
  auto f = [&](const Eigen::VectorXd& v) {
    const Positions p = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, x.cols());
    return term(p, nullptr);
  };
  const double scale = 0.3;  // um, the edge length
  const auto [e1, e2] = testing::fd_directional_errors(f, x0, flat(g), 1e-2 * scale, 5);
  // A term linear in x (the tweezers) has no truncation error: only round-off remains.
  const double roundoff = 1e-7 * (1.0 + flat(g).norm());
  if (e1 > roundoff) {
    EXPECT_GT(e1 / e2, 3.0) << what << ": error ratio for h -> h/2 should be ~4 (second order)";
  }
  const double h = std::cbrt(std::numeric_limits<double>::epsilon()) * scale;
  const double err = testing::fd_gradient_error(f, x0, flat(g), h, 40, 9);
  EXPECT_LT(err, 1e-6 * (1.0 + flat(g).cwiseAbs().maxCoeff())) << what;
}

TEST(DiscreteTerms, EveryTermGradientMatchesFiniteDifferences) {
  SmallCell c;
  const Network& n = c.net;
  expect_second_order_gradient(
      [&](const Positions& x, Positions* g) {
        Positions full = Positions::Zero(3, x.cols());
        const double e = network_energy(n, x, c.load, g ? &full : nullptr);
        if (g) *g = full;
        return e;
      },
      c.x, "total");
  expect_second_order_gradient(
      [&](const Positions& x, Positions* g) {
        return juelicher_bending_energy(x, n.topo, {0.2, 0.3}, g);
      },
      c.x, "juelicher with H0");
  expect_second_order_gradient(
      [&](const Positions& x, Positions* g) {
        return dihedral_bending_energy(x, n.topo, 0.7, 0.05, g);
      },
      c.x, "dihedral");
  expect_second_order_gradient(
      [&](const Positions& x, Positions* g) {
        return constraint_energy(x, n.topo, n.area0_um2, n.volume0_um3, n.constraints, {2, 1}, g);
      },
      c.x, "area/volume");
  expect_second_order_gradient(
      [&](const Positions& x, Positions* g) {
        return tweezers_energy(n.patch, 77.0, x, n.rest, g);
      },
      c.x, "tweezers");
  for (auto e : {WlcExpansion::order2, WlcExpansion::order3, WlcExpansion::order4}) {
    NetworkParameters p;
    p.expansion = e;
    SmallCell t(p);
    expect_second_order_gradient(
        [&](const Positions& x, Positions* g) { return network_energy(t.net, x, t.load, g); }, t.x,
        "taylor network");
  }
}

TEST(DiscreteTerms, RigidMotionsLeaveInternalEnergyUnchanged) {
  SmallCell c;
  LoadState free_load;  // no tweezers: their work is not rigid-invariant by design
  free_load.multipliers = c.load.multipliers;
  const double e0 = network_energy(c.net, c.x, free_load);
  const Eigen::Matrix3d rot =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
  Positions moved = (rot * c.x).colwise() + Eigen::Vector3d(0.3, -1.2, 2.0);
  EXPECT_NEAR(network_energy(c.net, moved, free_load), e0, 1e-9 * std::abs(e0));
}

TEST(DiscreteTerms, LengthScalingMatchesFixedDensity) {
  // Scaling the network (rest and current) by s scales link and steric energies by s^2
  // (a fixed areal density) and leaves the bending energy unchanged (scale invariant).
  SmallCell c;
  const double s = 1.7;
  TriMesh scaled{c.net.rest * s, c.net.topo};
  const Network big = build_network(scaled, NetworkParameters{});
  LoadState none;
  EnergyBreakdown a, b;
  network_energy(c.net, c.x, none, nullptr, &a);
  Positions xs = c.x * s;
  network_energy(big, xs, none, nullptr, &b);
  EXPECT_NEAR(b.links, s * s * a.links, 1e-9 * std::abs(b.links));
  EXPECT_NEAR(b.steric, s * s * a.steric, 1e-9 * std::abs(b.steric));
  EXPECT_NEAR(b.bending, a.bending, 1e-9 * std::abs(a.bending));
}

TEST(DiscreteTerms, LinkPastLmaxIsInfeasibleNotANumber) {
  SmallCell c;
  Positions x = c.net.rest;
  const int a = c.net.topo.edges(0, 0), b = c.net.topo.edges(1, 0);
  // Move b along the link until it exceeds Lmax_e = Lbar_e / x0.
  const Eigen::Vector3d d = (x.col(b) - x.col(a)).normalized();
  x.col(b) = x.col(a) + 1.01 * c.net.lbar_um(0) / c.net.wlc.x0 * d;
  Positions g;
  EXPECT_TRUE(std::isinf(network_energy(c.net, x, c.load, &g)));
}

TEST(Bending, JuelicherSphereGivesEightPiKappaAtAnyRadius) {
  const BendingParameters p{0.2, 0.0};
  for (double r : {0.5, 3.0, 40.0}) {
    const TriMesh m = testing::sphere_mesh(16, r);  // 2,562 vertices
    const double e = juelicher_bending_energy(m.x, m.topo, p);
    EXPECT_NEAR(e / (8 * units::pi * p.kappa_pNum), 1.0, 1e-2) << "radius " << r;
  }
}

TEST(Bending, JuelicherSphereConvergesUnderRefinement) {
  const BendingParameters p{1.0, 0.0};
  double prev = 0;
  for (int f : {4, 8, 16}) {
    const TriMesh m = testing::sphere_mesh(f, 1.0);
    const double err = std::abs(juelicher_bending_energy(m.x, m.topo, p) / (8 * units::pi) - 1);
    if (prev > 0) {
      EXPECT_LT(err, 0.5 * prev) << "frequency " << f;
    }
    prev = err;
  }
}

TEST(Bending, DihedralMappingsOnTheSphere) {
  // MODEL.md: k_b = 2 sqrt3 kappa matches 8 pi kappa on a near-equilateral sphere mesh;
  // Li et al.'s k_b = 2 kappa / sqrt3 gives a third of it.
  const TriMesh m = testing::sphere_mesh(16, 2.0);
  const double kappa = 0.2, target = 8 * units::pi * kappa;
  const double matched = dihedral_bending_energy(
      m.x, m.topo, dihedral_stiffness_pNum(kappa, DihedralMapping::sphere_matched), 0.0);
  const double li = dihedral_bending_energy(
      m.x, m.topo, dihedral_stiffness_pNum(kappa, DihedralMapping::li_et_al), 0.0);
  EXPECT_NEAR(matched / target, 1.0, 0.05);
  EXPECT_NEAR(li / target, 1.0 / 3.0, 0.02);
}

TEST(Network, RestShapeIsStressFreeInPlaneUpToPhi) {
  // MODEL.md: grad F_inplane(X) = (f_WLC(Lbar)/Lbar) grad Phi(X) on any mesh.
  RestShapeOptions o;
  o.target_vertices = 500;
  o.quality = RestMeshQuality::projected;
  const TriMesh m = make_rest_shape(o);
  const NetworkParameters p;
  const Network net = build_network(m, p);
  Positions g_phi;
  equilateral_defect(m.x, m.topo, &g_phi);
  const double f_lbar = wlc_tension_pN(p.wlc, p.wlc.lbar_um) / p.wlc.lbar_um;
  Positions g_in = Positions::Zero(3, m.x.cols());
  // In-plane part only: bending and constraints off, no force.
  NetworkParameters flat_p;
  flat_p.bending.kappa_pNum = 0.0;
  const Network nb = build_network(m, flat_p);
  LoadState none;
  network_energy(nb, m.x, none, &g_in);
  EXPECT_LT((g_in - f_lbar * g_phi).cwiseAbs().maxCoeff(), 1e-9 * g_in.cwiseAbs().maxCoeff());
  // The reported largest rest force is that closed form's largest vertex force (the in-plane
  // terms do not depend on the bending parameters).
  const double f_max = (f_lbar * g_phi).colwise().norm().maxCoeff();
  EXPECT_NEAR(largest_rest_inplane_force_pN(net), f_max, 1e-9 * f_max);
}

}  // namespace
}  // namespace rbc
