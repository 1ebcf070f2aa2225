// SPDX-License-Identifier: GPL-3.0-or-later
// The assembled continuum model and its constrained Newton solver: full-model derivatives,
// rigid-motion invariance, constraints held at every force, mesh convergence of the
// diameters, agreement with L-BFGS, infeasible steps and non-convergence reported.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <iomanip>
#include <iostream>
#include <limits>

#include "continuum/continuum_stretch.hpp"
#include "continuum_tangent_hessian.hpp"
#include "core/units.hpp"
#include "fixtures.hpp"
#include "hessian_check.hpp"
#include "homogenise/invariant_laws.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace {

ContinuumModel small_model(int elements, const BendingParameters& b = {}) {
  ContinuumParameters p;
  p.bending = b;
  return build_continuum_model(make_continuum_mesh(elements), testing::closed_form_p2_law(), p);
}

Positions unflat(const Eigen::VectorXd& v) {
  return Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, v.size() / 3);
}

TEST(ContinuumModel, LagrangianHessianMatchesFiniteDifferences) {
  const ContinuumModel m = small_model(320, {0.2, 0.3});
  Positions x = m.rest;
  testing::perturb(x, 0.03, 4);
  const ConstraintMultipliers l{2.0, -1.5};
  auto grad_l = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    const Positions p = unflat(v);
    Positions g;
    continuum_energy(m, p, 40.0, &g);
    const ConstraintValues c = evaluate_constraints(p, m.topo);
    return flat(
        Positions(g + l.area_pN_per_um * c.grad_area + l.volume_pN_per_um2 * c.grad_volume));
  };
  BlockHessian h(m.topo);
  h.set_zero();
  add_continuum_hessian(m, x, h);
  add_constraint_hessian(x, m.topo, l.area_pN_per_um, l.volume_pN_per_um2, h);
  const Eigen::SparseMatrix<double>& hm = h.matrix();
  for (unsigned s = 0; s < 3; ++s)
    testing::expect_hessian_ok(
        testing::check_hessian_direction(
            grad_l, flat(x), [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return hm * d; },
            0.5, s),
        "continuum Lagrangian");
  // And the gradient of the energy itself.
  Positions g;
  continuum_energy(m, x, 40.0, &g);
  const auto f = [&](const Eigen::VectorXd& v) { return continuum_energy(m, unflat(v), 40.0); };
  const auto [e1, e2] = testing::fd_directional_errors(f, flat(x), flat(g), 5e-3, 3);
  EXPECT_GT(e1 / e2, 3.0);
  EXPECT_LT(testing::fd_gradient_error(f, flat(x), flat(g), 2e-6, 30, 2),
            1e-6 * (1 + g.cwiseAbs().maxCoeff()));
}

TEST(ContinuumModel, RigidMotionsCostNothing) {
  const ContinuumModel m = small_model(320);
  Positions x = m.rest;
  testing::perturb(x, 0.05, 6);
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
  const Positions y = (r * x).colwise() + Eigen::Vector3d(3.0, -1.0, 0.5);
  ContinuumEnergyParts a, b;
  continuum_energy(m, x, 0.0, nullptr, &a);
  continuum_energy(m, y, 0.0, nullptr, &b);
  EXPECT_NEAR(a.inplane, b.inplane, 1e-12 * a.inplane);
  EXPECT_NEAR(a.bending, b.bending, 1e-12 * a.bending);
  // The rest mesh is stress free: no in-plane force at X on any mesh.
  Positions g = Positions::Zero(3, m.rest.cols());
  membrane_energy(m, m.rest, &g);
  EXPECT_LT(largest_vertex_norm(g), 1e-10);
}

TEST(ContinuumModel, CollapsedElementMakesTheStateInfeasible) {
  const ContinuumModel m = small_model(320);
  Positions x = m.rest;
  const auto t = m.topo.faces.col(0);
  x.col(t(2)) = 0.5 * (x.col(t(0)) + x.col(t(1)));
  EXPECT_TRUE(std::isinf(continuum_energy(m, x, 0.0)));
  EXPECT_THROW(make_continuum_mesh(100), std::invalid_argument);
  EXPECT_THROW(make_continuum_mesh(200000), std::invalid_argument);
}

TEST(ContinuumStretch, ConstraintsHeldAndDiametersMonotoneAtEveryForce) {
  const ContinuumModel m = small_model(500);
  const std::vector<double> forces = {0, 50, 100, 150, 193};
  const auto pts = run_continuum_stretch(m, forces, {});
  ASSERT_EQ(pts.size(), forces.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    EXPECT_TRUE(pts[i].converged) << pts[i].force_pN << " pN: " << to_string(pts[i].status);
    EXPECT_LT(pts[i].residual_pN, 1e-6);
    EXPECT_LT(std::abs(pts[i].area_drift), 1e-8);
    EXPECT_LT(std::abs(pts[i].volume_drift), 1e-8);
    EXPECT_NEAR(total_area(pts[i].x, m.topo) / m.area0_um2, 1.0, 1e-8);
    EXPECT_NEAR(enclosed_volume(pts[i].x, m.topo) / m.volume0_um3, 1.0, 1e-8);
    if (i > 0) {
      EXPECT_GT(pts[i].axial_um, pts[i - 1].axial_um);
      EXPECT_LT(pts[i].transverse_um, pts[i - 1].transverse_um);
    }
  }
  // Stretching raises I2 where the beads pull; the stress field is tensile along x there.
  EXPECT_GT(pts.back().fields.i2.maxCoeff(), 0.1);
  EXPECT_GT(pts.back().fields.tension_max_pN_per_um.maxCoeff(), 1.0);
  // Without the fields (ContinuumOptions::element_fields): the same solve, bit for bit, and
  // empty fields.
  ContinuumOptions bare;
  bare.element_fields = false;
  const auto lean = run_continuum_stretch(m, forces, bare);
  ASSERT_EQ(lean.size(), pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    EXPECT_EQ(lean[i].x, pts[i].x) << forces[i];
    EXPECT_EQ(lean[i].iterations, pts[i].iterations) << forces[i];
    EXPECT_EQ(lean[i].fields.i1.size(), 0);
    EXPECT_EQ(pts[i].fields.i1.size(), m.num_elements());
  }
}

TEST(ContinuumStretch, FloatFactorReachesTheDoubleFactorsEquilibria) {
  // NewtonOptions::factor_precision: with the Krylov correction the float factor only
  // preconditions, so the equilibria agree to the Newton tolerance (1e-6 pN; diameters within
  // 1e-7 relative) with about the same iterations; without the correction the factorisation
  // stays double, bit for bit.
  const ContinuumModel m = small_model(500);
  const std::vector<double> forces = {0, 88, 193};
  ContinuumOptions sgl, dbl;
  dbl.newton.factor_precision = SolvePrecision::double_precision;
  const auto a = run_continuum_stretch(m, forces, sgl);
  const auto b = run_continuum_stretch(m, forces, dbl);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_TRUE(a[i].converged && b[i].converged) << forces[i];
    EXPECT_NEAR(a[i].axial_um, b[i].axial_um, 1e-7 * b[i].axial_um) << forces[i];
    EXPECT_NEAR(a[i].transverse_um, b[i].transverse_um, 1e-7 * b[i].transverse_um) << forces[i];
    EXPECT_LE(std::abs(a[i].iterations - b[i].iterations), 2) << forces[i];
  }
  EXPECT_NE(a.back().x, b.back().x);  // the float factor does change the path
  ContinuumOptions sgl0 = sgl, dbl0 = dbl;
  sgl0.newton.krylov_iterations = dbl0.newton.krylov_iterations = 0;
  const auto c = run_continuum_stretch(m, forces, sgl0);
  const auto d = run_continuum_stretch(m, forces, dbl0);
  for (size_t i = 0; i < c.size(); ++i) EXPECT_EQ(c[i].x, d[i].x) << forces[i];
  // Nor with an initial shift at the correction's kept shift (calibrate's forward model), whose
  // lagged chord steps skip the correction: double, bit for bit.
  ContinuumOptions sgl8 = sgl, dbl8 = dbl;
  sgl8.newton.krylov_initial_shift = dbl8.newton.krylov_initial_shift = 1e-8;
  const auto e = run_continuum_stretch(m, forces, sgl8);
  const auto g = run_continuum_stretch(m, forces, dbl8);
  for (size_t i = 0; i < e.size(); ++i) EXPECT_EQ(e[i].x, g[i].x) << forces[i];
}

TEST(ContinuumStretch, DiametersAt88pNConvergeUnderRefinement) {
  std::vector<double> da, dt;
  for (int el : {320, 720, 1620}) {  // h ratio 1.5 between meshes
    const auto p = run_continuum_stretch(small_model(el), {44.0, 88.0}, {});
    ASSERT_TRUE(p.back().converged);
    da.push_back(p.back().axial_um);
    dt.push_back(p.back().transverse_um);
  }
  const double ca = std::abs(da[1] - da[0]) / std::abs(da[2] - da[1]);
  const double ct = std::abs(dt[1] - dt[0]) / std::abs(dt[2] - dt[1]);
  std::cout << "[ 88 pN ] D_A " << da[0] << " " << da[1] << " " << da[2] << " D_T " << dt[0] << " "
            << dt[1] << " " << dt[2] << "; observed orders " << std::log(ca) / std::log(1.5) << " "
            << std::log(ct) / std::log(1.5) << "\n";
  EXPECT_GT(ca, 1.5);  // successive differences shrink (order > 1 gives 1.5)
  EXPECT_GT(ct, 1.5);
  EXPECT_LT(std::abs(da[2] - da[1]) / da[2], 0.01);
}

TEST(ContinuumStretch, NewtonAgreesWithLbfgs) {
  const ContinuumModel m = small_model(320);
  ContinuumOptions o;
  const auto a = run_continuum_stretch(m, {60.0}, o);
  o.solver = ContinuumSolver::lbfgs;
  o.lbfgs.force_tolerance = 1e-5;
  o.newton.constraint_tolerance = 1e-8;
  o.lbfgs_area_stiffness = o.lbfgs_volume_stiffness = 1e3;
  const auto b = run_continuum_stretch(m, {60.0}, o);
  ASSERT_TRUE(a[0].converged);
  ASSERT_TRUE(b[0].converged) << to_string(b[0].status);
  EXPECT_NEAR(a[0].axial_um, b[0].axial_um, 1e-3);
  EXPECT_NEAR(a[0].transverse_um, b[0].transverse_um, 1e-3);
  EXPECT_NEAR(a[0].energy_pNum, b[0].energy_pNum, 1e-6 * std::abs(a[0].energy_pNum));
}

TEST(ContinuumStretch, HomogeniseOrderTwoLawGivesTheSameShape) {
  const TriMesh mesh = make_continuum_mesh(320);
  const ContinuumModel a = build_continuum_model(mesh, testing::closed_form_p2_law(), {});
  const ContinuumModel b = build_continuum_model(
      mesh, make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::order2), {});
  const auto pa = run_continuum_stretch(a, {88.0}, {});
  const auto pb = run_continuum_stretch(b, {88.0}, {});
  EXPECT_NEAR(pa[0].axial_um, pb[0].axial_um, 1e-8);
  EXPECT_NEAR(pa[0].transverse_um, pb[0].transverse_um, 1e-8);
}

TEST(ContinuumStretch, LargeJumpReachesTheSteppedEquilibriumAndNonConvergenceIsReported) {
  const ContinuumModel m = small_model(320);
  // One huge jump: steps that would collapse or flip elements are shortened, never NaN, and the
  // solve lands on the equilibrium the continuation 0, 50, ..., 300 pN reaches.
  const auto jump = run_continuum_stretch(m, {300.0}, {});
  const auto stepped = run_continuum_stretch(m, {0, 50, 100, 150, 200, 250, 300.0}, {});
  const ContinuumStretchPoint& a = jump[0];
  const ContinuumStretchPoint& b = stepped.back();
  ASSERT_TRUE(a.converged) << to_string(a.status);
  ASSERT_TRUE(b.converged) << to_string(b.status);
  EXPECT_TRUE(a.x.allFinite());
  EXPECT_LT(a.residual_pN, ContinuumOptions{}.newton.force_tolerance_pN);
  EXPECT_LT(b.residual_pN, ContinuumOptions{}.newton.force_tolerance_pN);
  // Both are strict constrained minima: the tangent-space Hessian is positive definite there.
  const double la = testing::smallest_tangent_eigenvalue(
      testing::tangent_hessian(m, a.x, a.multipliers, a.force_pN));
  const double lb = testing::smallest_tangent_eigenvalue(
      testing::tangent_hessian(m, b.x, b.multipliers, b.force_pN));
  ASSERT_GT(la, 0);
  ASSERT_GT(lb, 0);
  // Tolerances from the solver's stopping point. A state with net vertex forces r (largest
  // vertex norm rho, so |r|_2 <= sqrt(N) rho) lies within |r|_2 / lambda_min of the exact
  // equilibrium in the tangent space, and a relative area or volume drift eps changes lengths
  // by at most about eps: a diameter (a difference of two coordinates) moves by at most
  // 2 sqrt(N) rho / lambda_min + D (|eps_A| + |eps_V|) per solve. The Lagrangian
  // L = E + lambda_A (A - A0) + lambda_V (V - V0) is stationary at the equilibrium, so its error
  // is second order, N rho^2 / lambda_min per solve, plus the rounding of sums over the
  // elements: elements x machine epsilon x the magnitudes summed (|E| + 2 F D_A bounds the
  // in-plane, bending and work terms). The energy E itself differs by lambda . (A - A0, V - V0)
  // at first order, which the comparison of L removes.
  const double n = static_cast<double>(m.topo.num_vertices);
  const double lmin = std::min(la, lb);
  auto diameter_tol = [&](double d) {
    return 2 * std::sqrt(n) * (a.residual_pN + b.residual_pN) / lmin +
           d * (std::abs(a.area_drift) + std::abs(a.volume_drift) + std::abs(b.area_drift) +
                std::abs(b.volume_drift));
  };
  auto lagrangian = [&](const ContinuumStretchPoint& p) {
    return p.energy_pNum + p.multipliers.area_pN_per_um * m.area0_um2 * p.area_drift +
           p.multipliers.volume_pN_per_um2 * m.volume0_um3 * p.volume_drift;
  };
  const double energy_tol =
      n * (a.residual_pN * a.residual_pN + b.residual_pN * b.residual_pN) / lmin +
      m.num_elements() * std::numeric_limits<double>::epsilon() *
          (std::abs(b.energy_pNum) + 2 * 300.0 * b.axial_um);
  std::cout << "[ 300 pN ] jump - stepped: D_A " << a.axial_um - b.axial_um << " (tolerance "
            << diameter_tol(b.axial_um) << "), D_T " << a.transverse_um - b.transverse_um
            << " (tolerance " << diameter_tol(b.transverse_um) << ") um, L "
            << lagrangian(a) - lagrangian(b) << " (tolerance " << energy_tol
            << ") pN um; lambda_min " << la << ", " << lb << " pN/um\n";
  EXPECT_NEAR(a.axial_um, b.axial_um, diameter_tol(b.axial_um));
  EXPECT_NEAR(a.transverse_um, b.transverse_um, diameter_tol(b.transverse_um));
  EXPECT_NEAR(lagrangian(a), lagrangian(b), energy_tol);
  // An iteration budget too small to converge: reported with its residual.
  ContinuumOptions o;
  o.newton.max_iterations = 1;
  o.max_bisections = 0;
  const auto p = run_continuum_stretch(m, {150.0}, o);
  EXPECT_FALSE(p[0].converged);
  EXPECT_GT(p[0].residual_pN, o.newton.force_tolerance_pN);
  EXPECT_TRUE(std::isfinite(p[0].residual_pN));
  EXPECT_EQ(p[0].status, NewtonStatus::max_iterations);
  EXPECT_THROW(run_continuum_stretch(m, {-1.0}, {}), std::invalid_argument);
}

TEST(ContinuumStretch, LongForceStepAfterAShortOneConvergesToTheRefinedShape) {
  // 0 -> 38 -> 130 pN at kappa = 4e-20 J: a short force step followed by a long one, where a
  // secant predictor extrapolating the 0-38 pN increment 2.4 times starts 35 % off in area;
  // the bisection sub-steps must not restart from such a guess. At 5,120 elements as at 2,000
  // the solve converges, and the shapes agree (the discretisation error between 2,000 and
  // 5,120 elements is 0.3 %).
  BendingParameters b;
  b.kappa_pNum = units::joule_to_pNum(4e-20);
  std::vector<double> da;
  for (int el : {2000, 5120}) {
    const auto p = run_continuum_stretch(small_model(el, b), {0.0, 38.0, 130.0}, {});
    ASSERT_TRUE(p.back().converged) << el << ": " << to_string(p.back().status) << ", residual "
                                    << p.back().residual_pN << " pN";
    EXPECT_LT(p.back().residual_pN, ContinuumOptions{}.newton.force_tolerance_pN);
    da.push_back(p.back().axial_um);
  }
  EXPECT_NEAR(da[1], da[0], 0.01 * da[0]);
}

}  // namespace
}  // namespace rbc
