// SPDX-License-Identifier: GPL-3.0-or-later
// The library form of `rbc moduli`: the Theorem 3 check (Hartmann 2008 Sec. 3.4) against its
// closed form and invariances, and the study's JSON against the closed-form moduli.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "homogenise/lattice_density.hpp"
#include "homogenise/moduli.hpp"
#include "homogenise/moduli_study.hpp"

namespace rbc {
namespace {

TEST(Theorem3Check, RelaxedPatchIsAffineWithTheLatticeDensity) {
  const WlcParameters wlc;
  const NetworkMaterial m = make_network_material(wlc, StericParameters{});
  const PeriodicNetwork net = make_hexagonal_patch(4, wlc.lbar_um);
  const Theorem3Check c = theorem3_check(net, m, wlc.lbar_um);
  ASSERT_TRUE(c.relax.converged()) << to_string(c.relax.status);
  // From a start 0.1 Lbar off the affine map, the relaxation returns to it (Theorem 3) ...
  EXPECT_LT(c.max_displacement_over_lbar, 1e-8);
  // ... and its density is the closed-form lattice density Psi(F).
  EXPECT_NEAR(c.psi_patch_pN_per_um,
              lattice_density(m.w, m.C_pN_per_um, m.steric, Theorem3Options{}.F),
              1e-10 * std::abs(c.psi_lattice_pN_per_um));
  EXPECT_LT(std::abs(c.psi_relative_difference()), 1e-10);
  EXPECT_EQ(c.start_amplitude_over_lbar, 0.1);
}

TEST(Theorem3Check, DensityIsIndependentOfStartSeedAndFrame) {
  const WlcParameters wlc;
  const NetworkMaterial m = make_network_material(wlc, StericParameters{});
  const PeriodicNetwork net = make_hexagonal_patch(3, wlc.lbar_um);
  Theorem3Options a;
  const Theorem3Check ca = theorem3_check(net, m, wlc.lbar_um, a);
  Theorem3Options b = a;
  b.seed = 12345;  // another non-affine start
  b.start_amplitude_over_lbar = 0.2;
  const Theorem3Check cb = theorem3_check(net, m, wlc.lbar_um, b);
  Theorem3Options r = a;  // frame indifference: Psi(R F) = Psi(F)
  const double t = 0.7;
  r.F = (Eigen::Matrix2d() << std::cos(t), -std::sin(t), std::sin(t), std::cos(t)).finished() * a.F;
  const Theorem3Check cr = theorem3_check(net, m, wlc.lbar_um, r);
  ASSERT_TRUE(ca.relax.converged() && cb.relax.converged() && cr.relax.converged());
  const double tol = 1e-10 * std::abs(ca.psi_patch_pN_per_um);
  EXPECT_NEAR(cb.psi_patch_pN_per_um, ca.psi_patch_pN_per_um, tol);
  EXPECT_NEAR(cr.psi_patch_pN_per_um, ca.psi_patch_pN_per_um, tol);
  EXPECT_NEAR(cr.psi_lattice_pN_per_um, ca.psi_lattice_pN_per_um, tol);
  EXPECT_LT(cb.max_displacement_over_lbar, 1e-8);
}

TEST(Theorem3Check, RefusesAnInvertedDeformationOrALargeStart) {
  const WlcParameters wlc;
  const NetworkMaterial m = make_network_material(wlc, StericParameters{});
  const PeriodicNetwork net = make_hexagonal_patch(2, wlc.lbar_um);
  Theorem3Options o;
  o.F << 1.0, 0.0, 0.0, -1.0;
  EXPECT_THROW(theorem3_check(net, m, wlc.lbar_um, o), std::invalid_argument);
  o = {};
  o.start_amplitude_over_lbar = 0.6;
  EXPECT_THROW(theorem3_check(net, m, wlc.lbar_um, o), std::invalid_argument);
}

TEST(ModuliStudy, HexagonalJsonCarriesTheClosedFormsAndTheCheck) {
  const WlcParameters wlc;
  const StericParameters steric;
  ModuliStudyOptions o;
  o.cells = 2;
  const ModuliStudy s = run_moduli_study(wlc, steric, o);
  ASSERT_TRUE(s.converged) << s.failure;
  const LinearModuli closed = closed_form_moduli(wlc, steric);
  EXPECT_EQ(s.json.at("network"), "hex");
  EXPECT_DOUBLE_EQ(s.json.at("mu_closed_pN_per_um").get<double>(), closed.mu_pN_per_um);
  EXPECT_DOUBLE_EQ(s.json.at("K_closed_pN_per_um").get<double>(), closed.K_pN_per_um);
  // The perfect lattice's numerical moduli equal the closed forms (Sec. 4.3).
  EXPECT_LT(std::abs(s.json.at("mu_relative_difference").get<double>()), 1e-8);
  EXPECT_LT(std::abs(s.json.at("K_relative_difference").get<double>()), 1e-8);
  EXPECT_LT(std::abs(s.json.at("psi_patch_over_lattice_minus_1").get<double>()), 1e-10);
  EXPECT_EQ(s.json.at("cells"), 2);
  ModuliStudyOptions bad;
  bad.cells = kMaxHexagonalPatchCells + 1;
  EXPECT_THROW(run_moduli_study(wlc, steric, bad), std::invalid_argument);
  EXPECT_EQ(moduli_network_from_string("disordered"), ModuliNetwork::disordered);
  EXPECT_THROW(moduli_network_from_string("square"), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
