// SPDX-License-Identifier: GPL-3.0-or-later
// Moduli at a sampling temperature T on the periodic cell (homogenise/thermal_moduli.hpp),
// against independent truth: the zero-temperature Gamma-limit moduli as T -> 0, a
// zero-rest-length harmonic network whose thermal moduli equal its T = 0 ones at any T (closed
// form sqrt3/2 k on the hexagonal lattice) and whose mean energy is equipartition's, and the
// quasi-harmonic O(T) shift from ln det of the relaxed Hessian at low T.
#include <gtest/gtest.h>

#include <cmath>

#include "core/units.hpp"
#include "core/validation.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/moduli.hpp"
#include "homogenise/thermal_moduli.hpp"

namespace rbc {
namespace {

ThermalCellMaterial network_material() {
  ThermalCellMaterial m;
  m.network = make_network_material(WlcParameters{}, StericParameters{});
  return m;
}

PeriodicNetwork small_disordered() {
  DisorderOptions d;
  d.cells = 6;
  d.disorder = 0.5;
  d.spacing_um = WlcParameters{}.lbar_um;
  return make_disordered_network(d, 1);
}

/// |a - b| within `sigmas` standard errors plus an allowance, with a message.
::testing::AssertionResult within(const char* what, double a, double b, double error, double sigmas,
                                  double allowance = 0.0) {
  const double tol = sigmas * error + allowance;
  if (std::abs(a - b) <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << what << ": " << a << " vs " << b << ", difference "
                                       << a - b << " beyond " << tol << " (error " << error << ")";
}

/// T -> 0: the thermal moduli of the network (WLC + steric) equal the zero-temperature
/// Gamma-limit moduli (the Schur complement tangent of the relaxed cell; for the hexagonal
/// lattice the closed form of Theorem 3) within their error, where the error is the statistical
/// one plus two known, separately computed terms: the central difference's O(eps^2) truncation
/// (zero_temperature_cd - gamma_limit) and the O(T) quasi-harmonic shift, both < 1e-4.
void expect_low_temperature_limit(const PeriodicNetwork& net) {
  const ThermalCellMaterial m = network_material();
  ThermalModuliOptions o;
  o.temperature_K = 1e-3;
  o.sweeps = 1000;
  o.warmup_sweeps = 300;
  const ThermalModuliResult r = thermal_moduli(net, m, o);
  const double mu0 = r.gamma_limit.mu_pN_per_um, K0 = r.gamma_limit.K_pN_per_um;
  const double mu_allow =
      std::abs(r.zero_temperature_cd.mu_pN_per_um - mu0) +
      std::abs(r.quasi_harmonic.mu_pN_per_um - r.zero_temperature_cd.mu_pN_per_um);
  const double K_allow = std::abs(r.zero_temperature_cd.K_pN_per_um - K0) +
                         std::abs(r.quasi_harmonic.K_pN_per_um - r.zero_temperature_cd.K_pN_per_um);
  EXPECT_LT(mu_allow / mu0, 1e-4);
  EXPECT_LT(K_allow / K0, 1e-4);
  EXPECT_TRUE(within("mu", r.mu.value, mu0, r.mu.error, 4.0, mu_allow));
  EXPECT_TRUE(within("K", r.K.value, K0, r.K.error, 4.0, K_allow));
  EXPECT_GT(r.mu.error, 0.0);
  EXPECT_LT(r.mu.error / mu0, 1e-4);
  EXPECT_LT(r.K.error / K0, 1e-4);
  EXPECT_TRUE(
      within("equipartition", r.equipartition_ratio.value, 1.0, r.equipartition_ratio.error, 4.0));
}

TEST(ThermalModuli, LowTemperatureLimitIsTheGammaLimitHexagonal) {
  const PeriodicNetwork net = make_hexagonal_patch(6, WlcParameters{}.lbar_um);
  expect_low_temperature_limit(net);
  // Theorem 3: the Gamma-limit of the hexagonal patch is the closed form.
  ThermalModuliOptions o;
  o.temperature_K = 0.0;
  const ThermalModuliResult r0 = thermal_moduli(net, network_material(), o);
  const LinearModuli closed = closed_form_moduli(WlcParameters{}, StericParameters{});
  EXPECT_NEAR(r0.gamma_limit.mu_pN_per_um / closed.mu_pN_per_um, 1.0, 1e-9);
  EXPECT_NEAR(r0.gamma_limit.K_pN_per_um / closed.K_pN_per_um, 1.0, 1e-9);
}

TEST(ThermalModuli, LowTemperatureLimitIsTheGammaLimitDisordered) {
  expect_low_temperature_limit(small_disordered());
}

/// Zero-rest-length harmonic springs: E is quadratic in (F, u), so the fluctuation part of the
/// free energy does not depend on F and the thermal moduli are the T = 0 ones at any T. Truth:
/// on the hexagonal lattice the closed form mu = K = sqrt3/2 k (sum of |D_e|^2 = 3 n^2 a^2 over
/// the area sqrt3/2 n^2 a^2, moduli_from_tangent's combinations); on the disordered network the
/// second differences of the relaxed ENERGY (a dense solve here, not the library's stress).
/// Equipartition: the mean energy above the minimum is kB T/2 per degree of freedom.
Eigen::Vector3d harmonic_relaxed_energy_second_differences(const PeriodicNetwork& net, double k,
                                                           double h) {
  const int N = net.vertex_count();
  auto relaxed_energy = [&](const Eigen::Matrix2d& F) {
    // E(u) = k/2 sum |F D + u_j - u_i|^2: dense normal equations, vertex 0 pinned.
    Eigen::MatrixXd L = Eigen::MatrixXd::Zero(N, N);
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(N, 2);
    for (const PeriodicEdge& e : net.edges) {
      const Eigen::Vector2d fd = F * e.ref;
      L(e.i, e.i) += 1;
      L(e.j, e.j) += 1;
      L(e.i, e.j) -= 1;
      L(e.j, e.i) -= 1;
      b.row(e.j) -= fd.transpose();
      b.row(e.i) += fd.transpose();
    }
    const Eigen::MatrixXd u = L.bottomRightCorner(N - 1, N - 1).ldlt().solve(b.bottomRows(N - 1));
    double E = 0;
    for (const PeriodicEdge& e : net.edges) {
      const Eigen::Vector2d ui = e.i ? Eigen::Vector2d(u.row(e.i - 1)) : Eigen::Vector2d::Zero();
      const Eigen::Vector2d uj = e.j ? Eigen::Vector2d(u.row(e.j - 1)) : Eigen::Vector2d::Zero();
      E += 0.5 * k * (F * e.ref + uj - ui).squaredNorm();
    }
    return E;
  };
  Eigen::Matrix2d d1, d2;
  d1 << 1, 0, 0, -1;
  d2 << 0, 1, 1, 0;
  const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
  Eigen::Vector3d t;
  int c = 0;
  for (const Eigen::Matrix2d& D : {d1, d2, I})
    t[c++] = (relaxed_energy(I + h * D) - 2 * relaxed_energy(I) + relaxed_energy(I - h * D)) /
             (h * h) / net.reference_area_um2();
  return t;  // D : T : D for D1, D2, I
}

void expect_harmonic_thermal_equals_zero_temperature(const PeriodicNetwork& net, double mu_true,
                                                     double K_true) {
  ThermalCellMaterial m;
  m.law = CellLaw::harmonic;
  m.spring_pN_per_um = 10.0;
  for (double T : {300.0, 1000.0}) {
    ThermalModuliOptions o;
    o.temperature_K = T;
    o.sweeps = 3000;
    o.warmup_sweeps = 300;
    const ThermalModuliResult r = thermal_moduli(net, m, o);
    // Statistical error plus rounding (the coupled +-eps chains cancel the noise nearly exactly).
    const double round = 1e-9 * mu_true;
    EXPECT_TRUE(within("mu", r.mu.value, mu_true, r.mu.error, 4.0, round)) << T;
    EXPECT_TRUE(within("K", r.K.value, K_true, r.K.error, 4.0, round)) << T;
    EXPECT_TRUE(
        within("equipartition", r.equipartition_ratio.value, 1.0, r.equipartition_ratio.error, 4.0))
        << T;
    EXPECT_LT(r.equipartition_ratio.error, 0.01);
  }
}

TEST(ThermalModuli, HarmonicNetworkHexagonalClosedFormAtAnyTemperature) {
  const double k = 10.0;
  const double closed = 0.5 * units::sqrt3 * k;
  const PeriodicNetwork net = make_hexagonal_patch(6, WlcParameters{}.lbar_um);
  const Eigen::Vector3d t = harmonic_relaxed_energy_second_differences(net, k, 0.05);
  EXPECT_NEAR((t[0] + t[1]) / 8, closed, 1e-6 * closed);  // the two truths agree
  expect_harmonic_thermal_equals_zero_temperature(net, closed, closed);
}

TEST(ThermalModuli, HarmonicNetworkDisorderedEqualsRelaxedEnergyAtAnyTemperature) {
  const PeriodicNetwork net = small_disordered();
  const Eigen::Vector3d t = harmonic_relaxed_energy_second_differences(net, 10.0, 0.05);
  expect_harmonic_thermal_equals_zero_temperature(net, (t[0] + t[1]) / 8, t[2] / 4);
}

/// At low T the thermal shift of the network's moduli is the quasi-harmonic one,
/// kB T/(2 A0) d2/ds2 ln det H_uu (relaxed Hessians, no sampling): the sampled moduli at 30 K
/// agree with it, and the shift is many errors wide (a sampler or stress that misses the
/// fluctuations, or samples the wrong law, fails).
TEST(ThermalModuli, LowTemperatureShiftIsQuasiHarmonic) {
  const PeriodicNetwork net = make_hexagonal_patch(6, WlcParameters{}.lbar_um);
  ThermalModuliOptions o;
  o.temperature_K = 30.0;
  o.sweeps = 20000;
  o.warmup_sweeps = 3000;
  const ThermalModuliResult r = thermal_moduli(net, network_material(), o);
  EXPECT_TRUE(within("mu", r.mu.value, r.quasi_harmonic.mu_pN_per_um, r.mu.error, 4.0));
  EXPECT_TRUE(within("K", r.K.value, r.quasi_harmonic.K_pN_per_um, r.K.error, 4.0));
  EXPECT_GT(r.quasi_harmonic.mu_pN_per_um - r.zero_temperature_cd.mu_pN_per_um, 8 * r.mu.error);
  EXPECT_GT(r.quasi_harmonic.K_pN_per_um - r.zero_temperature_cd.K_pN_per_um, 8 * r.K.error);
}

TEST(ThermalModuli, IndependentOfThreadCount) {
  const PeriodicNetwork net = make_hexagonal_patch(4, WlcParameters{}.lbar_um);
  ThermalModuliOptions o;
  o.temperature_K = 300.0;
  o.sweeps = 200;
  o.warmup_sweeps = 50;
  o.threads = 1;
  const ThermalModuliResult a = thermal_moduli(net, network_material(), o);
  o.threads = 2;
  const ThermalModuliResult b = thermal_moduli(net, network_material(), o);
  EXPECT_EQ(a.mu.value, b.mu.value);
  EXPECT_EQ(a.K.value, b.K.value);
  EXPECT_EQ(a.mu.error, b.mu.error);
  EXPECT_EQ(a.tension_pN_per_um.value, b.tension_pN_per_um.value);
  EXPECT_EQ(a.equipartition_ratio.value, b.equipartition_ratio.value);
  EXPECT_EQ(a.step_um, b.step_um);
  o.seed = 2;  // and the seed does matter
  const ThermalModuliResult c = thermal_moduli(net, network_material(), o);
  EXPECT_NE(a.mu.value, c.mu.value);
}

TEST(ThermalModuli, RefusesBadOptions) {
  auto bad = [](auto change) {
    ThermalModuliOptions o;
    change(o);
    EXPECT_THROW(o.validate(), InvalidParameter);
  };
  bad([](ThermalModuliOptions& o) { o.temperature_K = -1; });
  bad([](ThermalModuliOptions& o) { o.temperature_K = 1001; });
  bad([](ThermalModuliOptions& o) { o.temperature_K = std::nan(""); });
  bad([](ThermalModuliOptions& o) { o.strain = 0; });
  bad([](ThermalModuliOptions& o) { o.strain = 0.06; });
  bad([](ThermalModuliOptions& o) { o.sweeps = 10; });  // fewer than the 20 batches
  bad([](ThermalModuliOptions& o) { o.batches = 3; });
  bad([](ThermalModuliOptions& o) { o.warmup_sweeps = -1; });
  bad([](ThermalModuliOptions& o) { o.target_acceptance = 1.0; });
  bad([](ThermalModuliOptions& o) { o.initial_step_um = 2.0; });
  bad([](ThermalModuliOptions& o) { o.blocks = 0; });
  EXPECT_NO_THROW(ThermalModuliOptions{}.validate());
  ThermalCellMaterial m;
  m.law = CellLaw::harmonic;  // spring constant 0
  EXPECT_THROW(thermal_moduli(make_hexagonal_patch(3, 0.075), m, ThermalModuliOptions{}),
               InvalidParameter);
  ThermalStudyOptions so;
  so.cells = 2;  // hexagonal cells below 3
  EXPECT_THROW(so.validate(), InvalidParameter);
}

}  // namespace
}  // namespace rbc
