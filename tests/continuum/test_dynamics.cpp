// SPDX-License-Identifier: GPL-3.0-or-later
// Backward-Euler dynamics of the continuum membrane (continuum/dynamics.hpp): energy
// decrease with exact constraints, first-order time-step convergence, the end of a stretch
// at the static equilibrium, and the Kelvin-Voigt relaxation of a flat patch.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include "continuum/continuum_stretch.hpp"
#include "continuum/dynamics.hpp"

#include "core/lbfgs.hpp"
#include "fixtures.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {
namespace {

struct SmallContinuumCell {
  TriMesh mesh = make_continuum_mesh(400);
  ContinuumModel model = build_continuum_model(
      mesh, make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::order2), {});
  /// Static equilibrium at F (Newton).
  ContinuumStretchPoint equilibrium(double force) const {
    ContinuumOptions o;
    return run_continuum_stretch(model, {force}, o).back();
  }
};

TrajectoryResult release(const SmallContinuumCell& c, const ContinuumStretchPoint& start,
                         double force, double dt, double duration, double tol_pN_per_s = 1.0) {
  ContinuumDynamicsOptions o;
  o.shear_viscosity_pN_s_per_um = 0.7;
  o.tolerance_pN_per_s = tol_pN_per_s;
  ContinuumDynamics dyn(c.model, o);
  TrajectoryOptions to;
  to.dt_s = dt;
  to.duration_s = duration;
  DynamicsState s{start.x, start.multipliers};
  return run_trajectory([&](double h, DynamicsState& st) { return dyn.step(force, h, st); },
                        [&](const DynamicsState& st) { return dyn.measure(force, st); }, s, to);
}

TEST(ContinuumDynamics, EnergyNeverIncreasesWithExactConstraints) {
  testing::OneOpenMpThread one;
  SmallContinuumCell c;
  const ContinuumStretchPoint eq = c.equilibrium(60.0);
  ASSERT_TRUE(eq.converged);
  const TrajectoryResult r = release(c, eq, 0.0, 0.01, 0.2);
  ASSERT_TRUE(r.converged) << r.status;
  ASSERT_EQ(r.samples.size(), 21u);
  for (size_t k = 1; k < r.samples.size(); ++k) {
    EXPECT_LE(r.samples[k].energy_pNum, r.samples[k - 1].energy_pNum + 1e-10) << k;
    EXPECT_LT(std::abs(r.samples[k].area_drift), 1e-9);
    EXPECT_LT(std::abs(r.samples[k].volume_drift), 1e-9);
  }
  EXPECT_LT(r.samples.back().axial_um, r.samples.front().axial_um - 0.1);  // it does recover
}

TEST(ContinuumDynamics, TimeStepConvergenceIsFirstOrder) {
  testing::OneOpenMpThread one;
  SmallContinuumCell c;
  const ContinuumStretchPoint eq = c.equilibrium(60.0);
  ASSERT_TRUE(eq.converged);
  std::vector<double> da;
  for (double dt : {0.02, 0.01, 0.005}) {
    const TrajectoryResult r = release(c, eq, 0.0, dt, 0.06);
    ASSERT_TRUE(r.converged) << r.status;
    da.push_back(r.samples.back().axial_um);
  }
  const double order = std::log2(std::abs(da[0] - da[1]) / std::abs(da[1] - da[2]));
  EXPECT_GT(order, 0.8) << da[0] << " " << da[1] << " " << da[2];
  EXPECT_LT(order, 1.25) << da[0] << " " << da[1] << " " << da[2];
}

TEST(ContinuumDynamics, StretchEndsAtTheStaticEquilibrium) {
  testing::OneOpenMpThread one;
  SmallContinuumCell c;
  const ContinuumStretchPoint rest = c.equilibrium(0.0);
  const ContinuumStretchPoint eq = c.equilibrium(60.0);
  ASSERT_TRUE(rest.converged && eq.converged);
  // Backward Euler is unconditionally stable: long steps reach the end state quickly; the
  // step tolerance 1e-4 pN/s x dt = 5e-6 pN is that of a static solve.
  const TrajectoryResult r = release(c, rest, 60.0, 0.05, 4.0, 1e-4);
  ASSERT_TRUE(r.converged) << r.status;
  EXPECT_NEAR(r.samples.back().axial_um / eq.axial_um, 1.0, 1e-4);
  EXPECT_NEAR(r.samples.back().transverse_um / eq.transverse_um, 1.0, 1e-4);
}

/// A flat patch of irregular linear membrane elements (z = 0) deformed homogeneously,
/// x_i = F X_i with F symmetric (the kinematics of a periodic patch of uniform strain),
/// advanced by backward Euler on E + D; returns the fitted relaxation time of the strain
/// along `mode` from s0 = 1e-4.
double flat_patch_relaxation_time(const Eigen::Matrix2d& mode, const MembraneViscosity& visc0,
                                  double tc_expected) {
  const IsotropicMembraneLaw law =
      make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::order2);
  const std::vector<std::array<Vec3, 3>> tris = {
      {Vec3(0, 0, 0), Vec3(1.0, 0.1, 0), Vec3(0.2, 0.9, 0)},
      {Vec3(1.0, 0.1, 0), Vec3(1.3, 1.1, 0), Vec3(0.2, 0.9, 0)},
      {Vec3(0, 0, 0), Vec3(0.4, -0.8, 0), Vec3(1.0, 0.1, 0)}};
  std::vector<MembraneReference> ref;
  for (const auto& t : tris) ref.push_back(make_membrane_reference(t[0], t[1], t[2]));
  MembraneViscosity visc = visc0;
  visc.dt_s = tc_expected / 200;  // backward-Euler rate bias dt/(2 t_c) = 0.25 %
  auto place = [](const Eigen::Matrix2d& F, const Vec3& X) {
    return Vec3(F(0, 0) * X(0) + F(0, 1) * X(1), F(1, 0) * X(0) + F(1, 1) * X(1), 0.0);
  };
  Eigen::Matrix2d F = Eigen::Matrix2d::Identity() + 1e-4 * mode;
  std::vector<double> ts, ys;
  auto strain = [&] {
    return (F - Eigen::Matrix2d::Identity()).cwiseProduct(mode).sum() / mode.squaredNorm();
  };
  ts.push_back(0);
  ys.push_back(std::log(strain()));
  for (int k = 1; k <= 400; ++k) {
    std::vector<MembraneReference> prev;
    for (const auto& t : tris)
      prev.push_back(make_membrane_reference(place(F, t[0]), place(F, t[1]), place(F, t[2])));
    const Objective f = [&](const Eigen::VectorXd& v, Eigen::VectorXd& g) {
      Eigen::Matrix2d Fv;
      Fv << v(0), v(1), v(1), v(2);
      Eigen::Matrix2d gf = Eigen::Matrix2d::Zero();
      double e = 0;
      for (size_t i = 0; i < tris.size(); ++i) {
        const Vec3 a = place(Fv, tris[i][0]), b = place(Fv, tris[i][1]), c = place(Fv, tris[i][2]);
        ElementGradient g1, g2;
        e += membrane_element_energy(law, ref[i], a, b, c, &g1);
        e += membrane_viscosity_element(visc, prev[i], a, b, c, &g2);
        for (int j = 0; j < 3; ++j)
          gf += (g1 + g2).segment<2>(3 * j) * tris[i][j].head<2>().transpose();
      }
      g = Eigen::Vector3d(gf(0, 0), gf(0, 1) + gf(1, 0), gf(1, 1));
      return e;
    };
    // Newton on the stationarity condition (3 unknowns, Jacobian by central differences of
    // the analytic gradient): energy differences at this tolerance are below E's round-off.
    Eigen::VectorXd v = Eigen::Vector3d(F(0, 0), F(0, 1), F(1, 1));
    auto grad = [&](const Eigen::VectorXd& y) {
      Eigen::VectorXd g;
      f(y, g);
      return g;
    };
    Eigen::VectorXd g = grad(v);
    for (int it = 0; it < 20 && g.cwiseAbs().maxCoeff() > 1e-10; ++it) {
      Eigen::Matrix3d jac;
      for (int c = 0; c < 3; ++c) {
        Eigen::VectorXd vp = v, vm = v;
        vp(c) += 1e-6;
        vm(c) -= 1e-6;
        jac.col(c) = (grad(vp) - grad(vm)) / 2e-6;
      }
      v -= jac.ldlt().solve(g);
      g = grad(v);
    }
    EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-10);
    F << v(0), v(1), v(1), v(2);
    ts.push_back(k * visc.dt_s);
    ys.push_back(std::log(strain()));
  }
  double st = 0, sy = 0, stt = 0, sty = 0;
  const double n = static_cast<double>(ts.size());
  for (size_t i = 0; i < ts.size(); ++i) {
    st += ts[i];
    sy += ys[i];
    stt += ts[i] * ts[i];
    sty += ts[i] * ys[i];
  }
  return -1.0 / ((n * sty - st * sy) / (n * stt - st * st));
}

TEST(ContinuumDynamics, FlatPatchShearRelaxesWithEtaOverMu) {
  const LinearModuli m = closed_form_moduli(WlcParameters{}, StericParameters{});
  MembraneViscosity v;
  v.shear_pN_s_per_um = 0.7;
  v.dilatational_pN_s_per_um = 1.4;
  const double tc = v.shear_pN_s_per_um / m.mu_pN_per_um;
  Eigen::Matrix2d shear;
  shear << 1, 0, 0, -1;
  EXPECT_NEAR(flat_patch_relaxation_time(shear, v, tc) / tc, 1.0, 0.02);
  Eigen::Matrix2d simple;
  simple << 0, 1, 1, 0;
  EXPECT_NEAR(flat_patch_relaxation_time(simple, v, tc) / tc, 1.0, 0.02);
}

TEST(ContinuumDynamics, FlatPatchDilatationRelaxesWithEtaDOverK) {
  const LinearModuli m = closed_form_moduli(WlcParameters{}, StericParameters{});
  MembraneViscosity v;
  v.shear_pN_s_per_um = 0.7;
  v.dilatational_pN_s_per_um = 1.4;
  const double tc = v.dilatational_pN_s_per_um / m.K_pN_per_um;
  EXPECT_NEAR(flat_patch_relaxation_time(Eigen::Matrix2d::Identity(), v, tc) / tc, 1.0, 0.02);
}

TEST(ContinuumDynamics, BadInputIsRejected) {
  TrajectoryOptions t;
  t.dt_s = 2.0;
  t.duration_s = 1.0;
  EXPECT_THROW(t.validate(), std::invalid_argument);
  t.dt_s = -1e-3;
  EXPECT_THROW(t.validate(), std::invalid_argument);
  ContinuumDynamicsOptions o;
  o.shear_viscosity_pN_s_per_um = 0.0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
