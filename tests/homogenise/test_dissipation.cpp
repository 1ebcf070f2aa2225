// SPDX-License-Identifier: GPL-3.0-or-later
// Homogenised dissipation of the link dashpots (homogenise/dissipation.hpp) and the
// relaxation of a periodic network patch under backward Euler (MODEL.md section 6).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/units.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/dissipation.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {
namespace {

constexpr double kGamma = 1.3;  // pN s/um

TEST(Dissipation, HexagonalLatticeReproducesClosedForms) {
  for (int n : {3, 4, 6})
    for (double a : {0.075, 1.0}) {
      const PeriodicNetwork net = make_hexagonal_patch(n, a);
      const MembraneViscosities v = affine_viscosities(net, kGamma);
      EXPECT_NEAR(v.shear_pN_s_per_um, units::sqrt3 * kGamma / 4, 1e-8) << n << " " << a;
      EXPECT_NEAR(v.dilatational_pN_s_per_um, units::sqrt3 * kGamma / 2, 1e-8) << n << " " << a;
    }
}

TEST(Dissipation, QuasiStaticHexagonalLatticeIsAffine) {
  // Theorem 3: the affine map minimises the elastic cell problem, so the non-affine
  // velocities vanish and the quasi-static viscosities equal the closed forms.
  const NetworkMaterial m = make_network_material(WlcParameters{}, StericParameters{});
  const PeriodicNetwork net = make_hexagonal_patch(4, 0.075);
  const QuasiStaticViscosities q = quasi_static_viscosities(net, m, kGamma);
  ASSERT_TRUE(q.converged) << q.largest_residual_pN;
  EXPECT_NEAR(q.viscosities.shear_pN_s_per_um, units::sqrt3 * kGamma / 4, 1e-8);
  EXPECT_NEAR(q.viscosities.dilatational_pN_s_per_um, units::sqrt3 * kGamma / 2, 1e-8);
}

TEST(Dissipation, DisorderedNetworkNonAffineVelocitiesChangeTheViscosity) {
  // A jittered network: its non-affine velocities are not zero, so R differs from the
  // affine value; the result is O(h^2)-converged in the strain step (two steps agree).
  const NetworkMaterial m = make_network_material(WlcParameters{}, StericParameters{});
  DisorderOptions o;
  o.cells = 6;
  o.disorder = 0.6;
  const PeriodicNetwork net = make_disordered_network(o, 3);
  QuasiStaticOptions qo;
  qo.strain_step = 1e-4;
  const QuasiStaticViscosities a = quasi_static_viscosities(net, m, kGamma, qo);
  qo.strain_step = 5e-5;
  const QuasiStaticViscosities b = quasi_static_viscosities(net, m, kGamma, qo);
  ASSERT_TRUE(a.converged && b.converged);
  EXPECT_GT(a.viscosities.shear_pN_s_per_um, 0.0);
  EXPECT_GT(std::abs(a.viscosities.shear_pN_s_per_um / a.affine.shear_pN_s_per_um - 1), 1e-3);
  EXPECT_NEAR(a.viscosities.shear_pN_s_per_um, b.viscosities.shear_pN_s_per_um,
              1e-5 * a.viscosities.shear_pN_s_per_um);
  EXPECT_NEAR(a.viscosities.dilatational_pN_s_per_um, b.viscosities.dilatational_pN_s_per_um,
              1e-5 * a.viscosities.dilatational_pN_s_per_um);
}

/// Relaxes an initial box strain s0 D with backward Euler and fits ln s(t) over [0, 2 t_c]
/// (returns 0 on a failed step).
double fitted_relaxation_time(const Eigen::Matrix2d& mode, double tc_expected) {
  const NetworkMaterial m = make_network_material(WlcParameters{}, StericParameters{});
  const PeriodicNetwork net = make_hexagonal_patch(3, 1.0);
  PatchState s;
  const double s0 = 1e-4;
  s.F = Eigen::Matrix2d::Identity() + s0 * mode;
  const double dt = tc_expected / 200;  // backward-Euler rate bias dt/(2 t_c) = 0.25 %
  auto strain = [&] {
    return (s.F - Eigen::Matrix2d::Identity()).cwiseProduct(mode).sum() / mode.squaredNorm();
  };
  std::vector<double> t, y;
  t.push_back(0);
  y.push_back(std::log(strain()));
  for (int k = 1; k <= 400; ++k) {
    if (!periodic_patch_step(net, m, kGamma, dt, s, 1e-10)) {
      ADD_FAILURE() << "step " << k << " did not converge";
      return 0.0;
    }
    t.push_back(k * dt);
    y.push_back(std::log(strain()));
  }
  double st = 0, sy = 0, stt = 0, sty = 0;
  const double nn = static_cast<double>(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    st += t[i];
    sy += y[i];
    stt += t[i] * t[i];
    sty += t[i] * y[i];
  }
  const double slope = (nn * sty - st * sy) / (nn * stt - st * st);
  return -1.0 / slope;
}

TEST(Dissipation, PeriodicPatchShearRelaxesWithEtaOverMu) {
  const LinearModuli mu = closed_form_moduli(WlcParameters{}, StericParameters{});
  const double tc = units::sqrt3 * kGamma / 4 / mu.mu_pN_per_um;
  Eigen::Matrix2d shear;
  shear << 1, 0, 0, -1;
  EXPECT_NEAR(fitted_relaxation_time(shear, tc) / tc, 1.0, 0.02);
}

TEST(Dissipation, PeriodicPatchDilatationRelaxesWithEtaDOverK) {
  const LinearModuli mu = closed_form_moduli(WlcParameters{}, StericParameters{});
  const double tc = units::sqrt3 * kGamma / 2 / mu.K_pN_per_um;
  EXPECT_NEAR(fitted_relaxation_time(Eigen::Matrix2d::Identity(), tc) / tc, 1.0, 0.02);
}

}  // namespace
}  // namespace rbc
