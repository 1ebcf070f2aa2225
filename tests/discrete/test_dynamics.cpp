// SPDX-License-Identifier: GPL-3.0-or-later
// Backward-Euler dynamics of the discrete network (discrete/dynamics.hpp) and the recovery
// fit of Hochmuth, Worthy & Evans (1979).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/io.hpp"
#include "discrete/dynamics.hpp"
#include "discrete/stretch.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

/// N ~ 250 network with the default constraint tolerance (1e-6 relative) and equilibria
/// at a largest net vertex force of 1e-5 pN: the floor plain L-BFGS reaches at this size
/// (at 1e-6 pN it stalls at the iteration limit after ~11,000 iterations).
struct SmallNetwork {
  Network net;
  SmallNetwork() {
    RestShapeOptions o;
    o.target_vertices = 250;
    net = build_network(make_rest_shape(o), NetworkParameters{});
  }
  StretchPoint equilibrium(double force, Positions& x, ConstraintMultipliers& l) const {
    StretchOptions so;
    so.minimiser.force_tolerance = 1e-5;
    return solve_equilibrium(net, force, x, l, so);
  }
};

TrajectoryResult run(const SmallNetwork& c, const DynamicsState& start, double force, double dt,
                     double duration, double tol_pN_per_s,
                     TimeScheme scheme = TimeScheme::backward_euler) {
  DiscreteDynamicsOptions o;
  o.tolerance_pN_per_s = tol_pN_per_s;
  o.scheme = scheme;
  TrajectoryOptions to;
  to.dt_s = dt;
  to.duration_s = duration;
  return run_trajectory(
      [&](double h, DynamicsState& s) { return discrete_dynamics_step(c.net, force, h, s, o); },
      [&](const DynamicsState& s) { return measure_discrete(c.net, force, s); }, start, to);
}

/// Largest vertex distance between two states (um).
double max_distance(const Positions& a, const Positions& b) {
  return (a - b).colwise().norm().maxCoeff();
}

/// Antisymmetric part of H = sum_i (x_i - c)(r_i - c_r)^T relative to |H|: zero when the
/// least-squares rotation of x onto r is the identity (no rigid rotation between them).
double relative_rotation(const Positions& x, const Positions& r) {
  const Eigen::Matrix3Xd p = x.colwise() - x.rowwise().mean();
  const Eigen::Matrix3Xd q = r.colwise() - r.rowwise().mean();
  const Eigen::Matrix3d h = p * q.transpose();
  return (h - h.transpose()).norm() / h.norm();
}

Eigen::Matrix3d finite_rotation() {
  return (Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -1.0, 0.5).normalized()) *
          Eigen::AngleAxisd(-0.4, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// Backward Euler over the constraint set: E(x_{n+1}) + D(x_{n+1}; x_n) <= E(x_n), so E never
// increases, up to the work lambda . (G - G0) the multipliers can do on constraints held to
// the tolerance t (|G - G0| <= t G0 at both ends of a step).
TEST(DiscreteDynamics, EnergyNeverIncreasesAlongARelease) {
  testing::OneOpenMpThread one;
  SmallNetwork c;
  DynamicsState s{c.net.rest, {}};
  ASSERT_TRUE(c.equilibrium(50.0, s.x, s.lambda).converged);
  const TrajectoryResult r = run(c, s, 0.0, 0.01, 0.05, 0.1);
  ASSERT_TRUE(r.converged) << r.status;
  ASSERT_EQ(r.samples.size(), 6u);
  const double t = c.net.constraints.tolerance;
  const double slack = 2 * t *
                       (std::abs(s.lambda.area_pN_per_um) * c.net.area0_um2 +
                        std::abs(s.lambda.volume_pN_per_um2) * c.net.volume0_um3);
  for (size_t k = 1; k < r.samples.size(); ++k) {
    EXPECT_LE(r.samples[k].energy_pNum, r.samples[k - 1].energy_pNum + slack) << k;
    EXPECT_LT(std::abs(r.samples[k].area_drift), t);
    EXPECT_LT(std::abs(r.samples[k].volume_drift), t);
  }
  // It does recover: the energy falls by most of the stored work, D_A shrinks.
  EXPECT_LT(r.samples.back().energy_pNum, r.samples.front().energy_pNum - 10 * slack - 1.0);
  EXPECT_LT(r.samples.back().axial_um, r.samples.front().axial_um - 0.5);
}

TEST(DiscreteDynamics, StretchEndsAtTheStaticEquilibrium) {
  testing::OneOpenMpThread one;
  SmallNetwork c;
  DynamicsState rest{c.net.rest, {}};
  ASSERT_TRUE(c.equilibrium(0.0, rest.x, rest.lambda).converged);
  Positions xe = rest.x;
  ConstraintMultipliers le = rest.lambda;
  const StretchPoint eq = c.equilibrium(50.0, xe, le);
  ASSERT_TRUE(eq.converged);
  // 10 steps of 0.5 s >> t_c ~ 0.1 s: the backward-Euler factor 1/(1 + dt/t_c) per step leaves
  // < 1e-7 of the initial distance; step tolerance 2e-5 pN/s x 0.5 s = 1e-5 pN, as the static.
  const TrajectoryResult r = run(c, rest, 50.0, 0.5, 5.0, 2e-5);
  ASSERT_TRUE(r.converged) << r.status;
  EXPECT_NEAR(r.samples.back().axial_um / eq.axial_um, 1.0, 1e-4);
  EXPECT_NEAR(r.samples.back().transverse_um / eq.transverse_um, 1.0, 1e-4);
  EXPECT_GT(eq.axial_um, rest.x.row(0).maxCoeff() - rest.x.row(0).minCoeff() + 1.0);
}

// The step's objective (F = 0) is blind to a finite rigid rotation: it costs no dissipation,
// a rotated equilibrium stays where it is, and the step commutes with the rotation.
TEST(DiscreteDynamics, RigidRotationStaysPutAndCostsNoDissipation) {
  testing::OneOpenMpThread one;
  SmallNetwork c;
  DynamicsState eq{c.net.rest, {}};
  ASSERT_TRUE(c.equilibrium(0.0, eq.x, eq.lambda).converged);
  const Eigen::Matrix3d q = finite_rotation();
  const Eigen::Vector3d shift(1.5, -0.7, 2.0);
  const Positions xq = (q * eq.x).colwise() + shift;
  LinkDashpotParameters dp;
  dp.gamma_pN_s_per_um = link_damping_for_shear_viscosity(0.7);
  dp.dt_s = 1e-3;
  Positions g = Positions::Zero(3, xq.cols());
  const double d = link_dashpot_energy(dp, c.net.topo, link_lengths(eq.x, c.net.topo), xq, &g);
  EXPECT_LT(d, 1e-18);
  EXPECT_LT(g.norm(), 1e-9);
  // From the rotated equilibrium a step (tolerance 1e-5 pN) does not move it.
  DiscreteDynamicsOptions o;
  o.tolerance_pN_per_s = 1e-2;
  DynamicsState s{xq, eq.lambda};
  const StepOutcome r = discrete_dynamics_step(c.net, 0.0, 1e-3, s, o);
  ASSERT_TRUE(r.converged) << r.status;
  EXPECT_LT(max_distance(s.x, xq), 1e-6);
}

// A release step from a perturbed, rotated, stretched state equals the rotated step from the
// unrotated state, and neither step contains a rigid rotation (the least-squares rotation
// from x_n to x_{n+1} is the identity to rounding).
TEST(DiscreteDynamics, ReleaseStepHasNoRigidRotationAndCommutesWithRotations) {
  testing::OneOpenMpThread one;
  SmallNetwork c;
  DynamicsState s{c.net.rest, {}};
  ASSERT_TRUE(c.equilibrium(50.0, s.x, s.lambda).converged);
  testing::perturb(s.x, 0.01, 5);
  DynamicsState sq{finite_rotation() * s.x, s.lambda};
  DiscreteDynamicsOptions o;
  o.tolerance_pN_per_s = 1e-3;  // 1e-5 pN at dt = 10 ms
  const Positions x0 = s.x, xq0 = sq.x;
  ASSERT_TRUE(discrete_dynamics_step(c.net, 0.0, 0.01, s, o).converged);
  ASSERT_TRUE(discrete_dynamics_step(c.net, 0.0, 0.01, sq, o).converged);
  EXPECT_GT(max_distance(s.x, x0), 0.05);  // the step does move the cell
  EXPECT_LT(relative_rotation(s.x, x0), 1e-12);
  EXPECT_LT(relative_rotation(sq.x, xq0), 1e-12);
  EXPECT_LT(max_distance(sq.x, finite_rotation() * s.x), 1e-4);
  EXPECT_LT((s.x.rowwise().mean() - x0.rowwise().mean()).norm(), 1e-12);
}

// At F > 0 only the rotation about the stretch axis is unseen: it is removed, and a state
// rotated about x by a finite angle steps like the unrotated one.
TEST(DiscreteDynamics, RotationAboutTheStretchAxisIsRemovedUnderLoad) {
  Positions x = Positions::Random(3, 40);
  const Eigen::Matrix3d rx = Eigen::AngleAxisd(0.9, Eigen::Vector3d::UnitX()).toRotationMatrix();
  Positions y = (rx * x).colwise() + Eigen::Vector3d(0.2, 0.3, -0.1);
  remove_unseen_rigid_motion(y, x, false);
  EXPECT_LT(max_distance(y, x), 1e-12);
  // A rotation about y is seen by the beads' work at F > 0 and is kept.
  const Eigen::Matrix3d ry = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Positions z = ry * x;
  remove_unseen_rigid_motion(z, x, false);
  EXPECT_GT(max_distance(z, x), 0.1);
  remove_unseen_rigid_motion(z, x, true);
  EXPECT_LT(max_distance(z, x), 1e-12);
}

// Time-step convergence at the scheme's order, on D_A(t = 0.04 s) of a release from 50 pN:
// with D(h) the value at step h, the ratio (D(h) - D(h/2)) / (D(h/2) - D(h/4)) tends to 2^p,
// p = 1 for backward Euler and 2 for BDF2 (h = 10, 5, 2.5 ms; t_c ~ 0.085 s). The step force
// tolerance, 1e-5 pN at 2.5 ms (the floor plain L-BFGS reaches here), keeps the solver's error
// below the smallest difference.
TEST(DiscreteDynamics, TimeStepConvergenceAtTheSchemesOrder) {
  testing::OneOpenMpThread one;
  SmallNetwork c;
  DynamicsState s{c.net.rest, {}};
  ASSERT_TRUE(c.equilibrium(50.0, s.x, s.lambda).converged);
  for (const TimeScheme scheme : {TimeScheme::backward_euler, TimeScheme::bdf2}) {
    std::vector<double> d;
    for (const double h : {0.01, 0.005, 0.0025}) {
      const TrajectoryResult r = run(c, s, 0.0, h, 0.04, 4e-3, scheme);
      ASSERT_TRUE(r.converged) << r.status;
      d.push_back(r.samples.back().axial_um);
    }
    const double ratio = (d[0] - d[1]) / (d[1] - d[2]);
    const double order = std::log2(ratio);
    if (scheme == TimeScheme::backward_euler) {
      EXPECT_GT(order, 0.85) << ratio;  // measured 0.92
      EXPECT_LT(order, 1.15) << ratio;
    } else {
      EXPECT_GT(order, 1.8) << ratio;  // measured 2.02
      EXPECT_LT(order, 2.25) << ratio;
    }
  }
}

// BDF2's first step has no x_{n-1} and is the backward-Euler step; the second is not.
TEST(DiscreteDynamics, SecondOrderSchemeStartsWithABackwardEulerStep) {
  testing::OneOpenMpThread one;
  SmallNetwork c;
  DynamicsState s{c.net.rest, {}};
  ASSERT_TRUE(c.equilibrium(50.0, s.x, s.lambda).converged);
  const TrajectoryResult be = run(c, s, 0.0, 0.01, 0.02, 2e-3);
  const TrajectoryResult b2 = run(c, s, 0.0, 0.01, 0.02, 2e-3, TimeScheme::bdf2);
  ASSERT_TRUE(be.converged && b2.converged);
  EXPECT_EQ(be.samples[1].axial_um, b2.samples[1].axial_um);
  EXPECT_GT(std::abs(be.samples[2].axial_um - b2.samples[2].axial_um), 1e-4);
}

/// Backward Euler of dx/dt = -x/tau (x in state.x(0, 0)) that "fails to converge" for
/// dt > dt_ok, with a residual of dt pN.
StepFunction decay_step(double tau, double dt_ok) {
  return [=](double dt, DynamicsState& s) {
    StepOutcome r;
    r.iterations = 1;
    r.residual_pN = dt;
    if (dt > dt_ok * (1 + 1e-12)) {
      r.status = "iteration limit reached";
      return r;
    }
    s.x(0, 0) /= 1 + dt / tau;
    r.converged = true;
    r.status = "converged";
    return r;
  };
}

TrajectorySample decay_measure(const DynamicsState& s) {
  TrajectorySample t;
  t.axial_um = s.x(0, 0);
  return t;
}

// A step that fails is redone as two half steps, recursively (bounded), and each halving is
// reported; the result is the backward-Euler solution at the halved step.
TEST(Trajectory, FailingStepsAreHalvedAndReported) {
  TrajectoryOptions o;
  o.duration_s = 0.05;
  o.dt_s = 0.01;
  o.max_halvings = 4;
  std::vector<std::string> messages;
  const ProgressSink sink = [&](const std::string& m) { messages.push_back(m); };
  const TrajectoryResult r = run_trajectory(decay_step(0.1, 0.003), decay_measure,
                                            DynamicsState{Positions::Ones(3, 1), {}}, o, sink);
  ASSERT_TRUE(r.converged) << r.status;
  EXPECT_EQ(r.halved_steps, 5);  // every step, each as four steps of 2.5 ms
  ASSERT_EQ(r.samples.size(), 6u);
  EXPECT_NEAR(r.samples.back().t_s, 0.05, 1e-15);
  EXPECT_NEAR(r.samples.back().axial_um, std::pow(1 + 0.0025 / 0.1, -20), 1e-14);
  int halving_lines = 0;
  for (const auto& m : messages)
    if (m.find("dt halved down to 0.0025 s") != std::string::npos) ++halving_lines;
  EXPECT_EQ(halving_lines, 5);
}

// The halving is bounded: past max_halvings the trajectory stops, converged = false, with the
// residual in scientific notation; no step is silently clamped.
TEST(Trajectory, HalvingIsBoundedAndTheFailureIsReported) {
  TrajectoryOptions o;
  o.duration_s = 0.05;
  o.dt_s = 0.01;
  o.max_halvings = 3;
  const TrajectoryResult r = run_trajectory(decay_step(0.1, 1e-4), decay_measure,
                                            DynamicsState{Positions::Ones(3, 1), {}}, o);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.samples.size(), 1u);  // only t = 0
  EXPECT_NE(r.status.find("after 3 halvings"), std::string::npos) << r.status;
  EXPECT_NE(r.status.find("1.250000e-03 pN"), std::string::npos) << r.status;  // dt / 8
}

TEST(Trajectory, BadTimesAreRefusedNamingTheValue) {
  const auto message = [](double duration, double dt) {
    TrajectoryOptions o;
    o.duration_s = duration;
    o.dt_s = dt;
    try {
      o.validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message(1.0, 0.0).find("dt"), std::string::npos);
  EXPECT_NE(message(1.0, -1e-3).find("dt"), std::string::npos);
  EXPECT_NE(message(0.0, 1e-3).find("duration"), std::string::npos);
  EXPECT_NE(message(-1.0, 1e-3).find("duration"), std::string::npos);
  EXPECT_NE(message(1.0, 2.0).find("exceed"), std::string::npos);
  EXPECT_NE(message(std::nan(""), 1e-3).find("duration"), std::string::npos);
  EXPECT_EQ(message(1.0, 1.0), "");
  DiscreteDynamicsOptions d;
  d.shear_viscosity_pN_s_per_um = 0.0;
  EXPECT_THROW(d.validate(), std::invalid_argument);
  d.shear_viscosity_pN_s_per_um = -0.7;
  EXPECT_THROW(d.validate(), std::invalid_argument);
}

TEST(RecoveryFit, RecoversAnExactExponential) {
  std::vector<double> t, l;
  const double linf = 1.1, tc = 0.12, m0 = 0.3;
  for (int i = 0; i <= 100; ++i) {
    t.push_back(0.005 * i);
    const double m = m0 * std::exp(-t.back() / tc);
    l.push_back(linf * (1 + m) / (1 - m));
  }
  const RecoveryFit f = fit_recovery(t, l, linf);
  ASSERT_TRUE(f.valid);
  EXPECT_NEAR(f.recovery_time_s, tc, 1e-10);
  EXPECT_NEAR(f.m0, m0, 1e-10);
  EXPECT_LT(f.recovery_time_err_s, 1e-10);
  const RecoveryFit g = fit_recovery_free_limit(t, l);
  EXPECT_NEAR(g.recovery_time_s, tc, 2e-3);
  EXPECT_NEAR(g.lambda_inf, linf, 1e-3);
}

TEST(RecoveryFit, HochmuthCurveGivesAboutATenthOfASecond) {
  const CsvTable d = read_csv(std::string(RBC_SOURCE_DIR) + "/data/hochmuth1979_recovery.csv");
  std::vector<double> t, l;
  for (const auto& row : d.rows) {
    t.push_back(row[0]);
    l.push_back(row[1]);
  }
  const RecoveryFit f = fit_recovery_free_limit(t, l);
  ASSERT_TRUE(f.valid);
  // MODEL.md section 6: a fit of this curve gives t_c ~ 0.11 s (paper: 0.1-0.13 s).
  EXPECT_GT(f.recovery_time_s, 0.08);
  EXPECT_LT(f.recovery_time_s, 0.14);
}

}  // namespace
}  // namespace rbc
