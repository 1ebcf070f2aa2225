// SPDX-License-Identifier: GPL-3.0-or-later
// Disordered periodic networks from periodic Delaunay: topology on the torus, relaxation
// lowers energy and stiffness, the Schur tangent is the second derivative of the relaxed
// energy, and X = 0 recovers the lattice.
#include <gtest/gtest.h>

#include <cmath>

#include "homogenise/disordered_network.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {
namespace {

TEST(DisorderedNetwork, IsATriangulationOfTheTorus) {
  DisorderOptions o;
  o.cells = 6;
  o.disorder = 1.0;
  for (unsigned seed : {1u, 2u, 3u}) {
    const PeriodicNetwork net = make_disordered_network(o, seed);
    const int N = net.vertex_count();
    EXPECT_EQ(N, o.cells * disordered_rows(o.cells));
    // Euler characteristic of the torus: V - E + F = 0 with 3F = 2E, so E = 3V, F = 2V.
    EXPECT_EQ(static_cast<int>(net.edges.size()), 3 * N);
    EXPECT_EQ(static_cast<int>(net.faces.size()), 2 * N);
    double area = 0.0;
    for (const PeriodicFace& f : net.faces) area += f.abar_um2;
    EXPECT_NEAR(area / net.reference_area_um2(), 1.0, 1e-12);
  }
}

TEST(DisorderedNetwork, RelaxationLowersEnergyAndModuli) {
  const NetworkMaterial m = make_network_material(WlcParameters{}, StericParameters{});
  DisorderOptions o;
  o.cells = 6;
  o.disorder = 1.0;
  for (unsigned seed : {1u, 2u}) {
    const DisorderedSample s = analyse_disordered(o, m, seed);
    ASSERT_TRUE(s.relax.converged()) << s.relax.residual_pN;
    EXPECT_GT(s.degree6_fraction, 0.0);
    EXPECT_LT(s.degree6_fraction, 1.0);
    EXPECT_LE(s.psi_relaxed_pN_per_um, s.psi_reference_pN_per_um);
    // Schur complement subtracts a positive semi-definite form: relaxed <= affine at the
    // same state, for every deformation mode.
    EXPECT_LE(s.relaxed.mu_pN_per_um, s.affine_at_relaxed.mu_pN_per_um * (1 + 1e-12));
    EXPECT_LE(s.relaxed.K_pN_per_um, s.affine_at_relaxed.K_pN_per_um * (1 + 1e-12));
    // And below the Cauchy-Born moduli of the unrelaxed reference.
    EXPECT_LT(s.relaxed.mu_pN_per_um, s.affine.mu_pN_per_um);
    EXPECT_LT(s.relaxed.K_pN_per_um, s.affine.K_pN_per_um);
    // A non-equilateral network keeps an isotropic tension (MODEL.md section 2).
    EXPECT_GT(s.phi_over_area, 0.0);
    EXPECT_GT(s.prestress_pN_per_um, 0.0);
  }
}

TEST(DisorderedNetwork, SchurTangentIsTheSecondDerivativeOfTheRelaxedEnergy) {
  const NetworkMaterial m = make_network_material(WlcParameters{}, StericParameters{});
  DisorderOptions o;
  o.cells = 5;
  o.disorder = 0.8;
  const PeriodicNetwork net = make_disordered_network(o, 4);
  const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
  const HomogenisedState h0 = homogenise_patch(net, m, I);
  ASSERT_TRUE(h0.relax.converged());
  Eigen::Matrix2d D;
  D << 0.7, -0.4, 0.3, -0.2;
  const Eigen::Vector4d d(D(0, 0), D(0, 1), D(1, 0), D(1, 1));
  const double analytic = d.dot(h0.relaxed_tangent * d);
  auto psi = [&](double s) {
    const HomogenisedState h = homogenise_patch(net, m, I + s * D, h0.relax.U);
    EXPECT_TRUE(h.relax.converged());
    return h.psi_pN_per_um;
  };
  auto err = [&](double step) {
    return std::abs((psi(step) - 2 * h0.psi_pN_per_um + psi(-step)) / (step * step) - analytic);
  };
  const double e1 = err(4e-3), e2 = err(2e-3);
  EXPECT_LT(e1, 1e-4 * analytic);
  EXPECT_GT(e1 / e2, 3.0);
  // The affine tangent misses the relaxation: clearly larger along this mode.
  EXPECT_GT(d.dot(h0.affine_tangent * d), analytic * (1 + 1e-6));
}

TEST(DisorderedNetwork, ZeroDisorderIsTheNearlyEquilateralLattice) {
  // cells = 26 gives 30 rows: row spacing within 0.07 % of sqrt3/2 a.
  const NetworkMaterial m = make_network_material(WlcParameters{}, StericParameters{});
  DisorderOptions o;
  o.cells = 26;
  o.disorder = 0.0;
  ASSERT_LT(std::abs(disordered_row_distortion(o.cells)), 1e-3);
  const DisorderedSample s = analyse_disordered(o, m, 1);
  ASSERT_TRUE(s.relax.converged());
  EXPECT_DOUBLE_EQ(s.degree6_fraction, 1.0);
  const LinearModuli ref = closed_form_moduli(m.w, m.steric);
  EXPECT_NEAR(s.relaxed.mu_pN_per_um / ref.mu_pN_per_um, 1.0, 1e-2);
  EXPECT_NEAR(s.relaxed.K_pN_per_um / ref.K_pN_per_um, 1.0, 1e-2);
}

TEST(DisorderedNetwork, BadOptionsAreRejected) {
  DisorderOptions o;
  o.disorder = 1.5;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.disorder = -0.1;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.disorder = 0.5;
  o.cells = 2;
  EXPECT_THROW(make_disordered_network(o, 1), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
