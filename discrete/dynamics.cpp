// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/dynamics.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <Eigen/SVD>

#include "core/geometry.hpp"
#include "core/lbfgs.hpp"
#include "core/validation.hpp"
#include "discrete/stretch.hpp"

namespace rbc {

void TrajectoryOptions::validate() const {
  if (!(duration_s > 0) || !std::isfinite(duration_s))
    throw std::invalid_argument("duration must be finite and > 0 s, got " +
                                format_number(duration_s));
  if (!(dt_s > 0) || !std::isfinite(dt_s))
    throw std::invalid_argument("time step dt must be finite and > 0 s, got " +
                                format_number(dt_s));
  if (dt_s > duration_s)
    throw std::invalid_argument("time step dt = " + format_number(dt_s) +
                                " s must not exceed the duration " + format_number(duration_s) +
                                " s");
  if (max_halvings < 0 || sample_every < 1)
    throw std::invalid_argument("max_halvings must be >= 0 and sample_every >= 1");
}

namespace {

/// Advances by dt, as two half steps (recursively) if the full step fails.
StepOutcome step_with_halving(const StepFunction& step, double dt, DynamicsState& s, int depth,
                              int max_depth, bool& halved, double& smallest_dt) {
  smallest_dt = std::min(smallest_dt, dt);
  DynamicsState trial = s;
  StepOutcome r = step(dt, trial);
  if (r.converged) {
    s = std::move(trial);
    return r;
  }
  if (depth >= max_depth) return r;
  halved = true;
  DynamicsState half = s;
  StepOutcome a =
      step_with_halving(step, 0.5 * dt, half, depth + 1, max_depth, halved, smallest_dt);
  if (!a.converged) return a;
  StepOutcome b =
      step_with_halving(step, 0.5 * dt, half, depth + 1, max_depth, halved, smallest_dt);
  if (!b.converged) return b;
  b.iterations += a.iterations + r.iterations;
  s = std::move(half);
  return b;
}

}  // namespace

TrajectoryResult run_trajectory(const StepFunction& step, const Measure& measure,
                                DynamicsState state, const TrajectoryOptions& o,
                                const ProgressSink& progress) {
  o.validate();
  const auto start = std::chrono::steady_clock::now();
  TrajectoryResult out;
  TrajectorySample s0 = measure(state);
  s0.t_s = 0.0;
  out.samples.push_back(s0);
  out.snapshots.push_back(state.x);
  const long steps = std::lround(std::ceil(o.duration_s / o.dt_s - 1e-9));
  int iterations = 0;
  for (long k = 1; k <= steps; ++k) {
    const double t_prev = (k - 1) * o.dt_s;
    const double t = std::min(k * o.dt_s, o.duration_s);
    bool halved = false;
    double smallest_dt = t - t_prev;
    const StepOutcome r =
        step_with_halving(step, t - t_prev, state, 0, o.max_halvings, halved, smallest_dt);
    iterations += r.iterations;
    out.residual_pN = r.residual_pN;
    if (halved) {
      ++out.halved_steps;
      std::ostringstream m;
      m << "step to t = " << t << " s: dt halved down to " << smallest_dt
        << " s (the step did not converge at dt = " << t - t_prev << " s)"
        << (r.converged ? "" : "; it failed at the smallest dt");
      report(progress, m.str());
    }
    if (!r.converged) {
      out.converged = false;
      std::ostringstream m;
      m << "step to t = " << t << " s did not converge after " << o.max_halvings
        << " halvings of dt: " << r.status << ", residual " << std::scientific << r.residual_pN
        << " pN";
      out.status = m.str();
      break;
    }
    if (k % o.sample_every == 0 || k == steps) {
      TrajectorySample s = measure(state);
      s.t_s = t;
      s.iterations = iterations;
      iterations = 0;
      out.samples.push_back(s);
      out.snapshots.push_back(state.x);
      if (progress && (k % std::max<long>(1, steps / 20) == 0 || k == steps)) {
        std::ostringstream m;
        m << "  t = " << t << " s: D_A = " << s.axial_um << " um, D_T = " << s.transverse_um
          << " um, E = " << s.energy_pNum << " pN um";
        report(progress, m.str());
      }
    }
  }
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

void DiscreteDynamicsOptions::validate() const {
  if (!(shear_viscosity_pN_s_per_um > 0) || !std::isfinite(shear_viscosity_pN_s_per_um))
    throw std::invalid_argument("membrane viscosity must be finite and > 0 pN s/um, got " +
                                format_number(shear_viscosity_pN_s_per_um));
  if (!(tolerance_pN_per_s > 0))
    throw std::invalid_argument("dynamics tolerance must be > 0 pN/s, got " +
                                format_number(tolerance_pN_per_s));
  if (max_iterations < 1 || max_outer_iterations < 1)
    throw std::invalid_argument("dynamics iteration counts must be >= 1");
}

void remove_unseen_rigid_motion(Positions& x, const Positions& reference, bool full_rotation) {
  const Eigen::Vector3d c = x.rowwise().mean(), c_ref = reference.rowwise().mean();
  const Eigen::Matrix3Xd p = x.colwise() - c;
  const Eigen::Matrix3Xd q = reference.colwise() - c_ref;
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();
  if (full_rotation) {
    // Kabsch: H = sum p q^T = U S V^T, R = V diag(1, 1, det(V U^T)) U^T minimises
    // sum |R p_i - q_i|^2 over proper rotations.
    const Eigen::Matrix3d h = p * q.transpose();
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
    d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
    rot = svd.matrixV() * d * svd.matrixU().transpose();
  } else {
    // Rotation by theta about x: minimises sum |R p_i - q_i|^2 in the y-z plane at
    // tan theta = sum (p x q)_x / sum (p_y q_y + p_z q_z).
    const double cross =
        (p.row(1).array() * q.row(2).array() - p.row(2).array() * q.row(1).array()).sum();
    const double dot =
        (p.row(1).array() * q.row(1).array() + p.row(2).array() * q.row(2).array()).sum();
    const double theta = std::atan2(cross, dot);
    rot(1, 1) = rot(2, 2) = std::cos(theta);
    rot(2, 1) = std::sin(theta);
    rot(1, 2) = -rot(2, 1);
  }
  x = (rot * p).colwise() + c_ref;
}

StepOutcome discrete_dynamics_step(const Network& net, double force_pN, double dt,
                                   DynamicsState& state, const DiscreteDynamicsOptions& o) {
  validate_discrete_force(force_pN);
  const int n = net.topo.num_vertices;
  LinkDashpotParameters dp;
  dp.gamma_pN_s_per_um = link_damping_for_shear_viscosity(o.shear_viscosity_pN_s_per_um);
  dp.dt_s = dt;
  dp.validate();
  Eigen::VectorXd lprev = link_lengths(state.x, net.topo);
  const bool two_step = o.scheme == TimeScheme::bdf2 && state.previous_dt_s > 0 &&
                        state.previous_x.cols() == state.x.cols();
  if (two_step) {
    const double w = dt / state.previous_dt_s;
    const double a = (1 + 2 * w) / (1 + w);
    lprev = ((1 + w) * lprev - (w * w / (1 + w)) * link_lengths(state.previous_x, net.topo)) / a;
    dp.gamma_pN_s_per_um *= a;
  }
  LoadState load;
  load.force_pN = force_pN;
  LbfgsOptions lo;
  lo.force_tolerance = o.tolerance_pN_per_s * dt;
  lo.max_iterations = o.max_iterations;
  lo.max_step = 0.25 * net.lbar_um.minCoeff();
  Eigen::VectorXd u = flat(state.x);
  const Objective f = [&](const Eigen::VectorXd& v, Eigen::VectorXd& g) {
    const Positions p = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, n);
    Positions gp;
    double e = network_energy(net, p, load, &gp);
    if (!std::isfinite(e)) return e;
    e += link_dashpot_energy(dp, net.topo, lprev, p, &gp);
    g = flat(gp);
    return e;
  };
  StepOutcome out;
  ConstraintMultipliers lambda = state.lambda;
  double previous_violation = std::numeric_limits<double>::infinity();
  for (int outer = 0; outer < o.max_outer_iterations; ++outer) {
    load.multipliers = lambda;
    const MinimiserResult r = minimise_lbfgs(f, u, lo);
    out.iterations += r.iterations;
    out.residual_pN = r.residual;
    if (!r.converged()) {
      out.status = to_string(r.status);
      return out;
    }
    Eigen::Map<const Eigen::Matrix3Xd> p(u.data(), 3, n);
    const double a = total_area(p, net.topo), v = enclosed_volume(p, net.topo);
    const double da = (a - net.area0_um2) / net.area0_um2;
    const double dv = (v - net.volume0_um3) / net.volume0_um3;
    if (std::abs(da) < net.constraints.tolerance && std::abs(dv) < net.constraints.tolerance) {
      Positions x = p;
      remove_unseen_rigid_motion(x, state.x, force_pN == 0.0);
      state.previous_x = state.x;
      state.previous_dt_s = dt;
      state.x = x;
      state.lambda = lambda;
      out.converged = true;
      out.status = "converged";
      return out;
    }
    lambda.area_pN_per_um +=
        load.stiffness_scale * net.constraints.area_stiffness_pN_per_um3 * (a - net.area0_um2);
    lambda.volume_pN_per_um2 +=
        load.stiffness_scale * net.constraints.volume_stiffness_pN_per_um5 * (v - net.volume0_um3);
    const double violation = std::max(std::abs(da), std::abs(dv));
    if (violation > 0.25 * previous_violation) load.stiffness_scale *= 10.0;
    previous_violation = violation;
  }
  out.status = "constraints not held after multiplier updates";
  return out;
}

RecoveryFit fit_recovery(const std::vector<double>& t, const std::vector<double>& lambda,
                         double lambda_inf, double low_fraction) {
  if (t.size() != lambda.size())
    throw std::invalid_argument("recovery fit: time and ratio series differ in length");
  RecoveryFit fit;
  fit.lambda_inf = lambda_inf;
  if (t.empty()) return fit;
  const double m_start = (lambda[0] - lambda_inf) / (lambda[0] + lambda_inf);
  std::vector<double> ts, ys;
  for (size_t i = 0; i < t.size(); ++i) {
    const double m = (lambda[i] - lambda_inf) / (lambda[i] + lambda_inf);
    if (!(m > low_fraction * m_start) || !(m > 0)) break;
    ts.push_back(t[i]);
    ys.push_back(std::log(m));
  }
  fit.points = static_cast<int>(ts.size());
  if (fit.points < 3) return fit;
  const double n = fit.points;
  double st = 0, sy = 0;
  for (int i = 0; i < fit.points; ++i) {
    st += ts[i];
    sy += ys[i];
  }
  const double tm = st / n, ym = sy / n;
  double stt = 0, sty = 0;
  for (int i = 0; i < fit.points; ++i) {
    stt += (ts[i] - tm) * (ts[i] - tm);
    sty += (ts[i] - tm) * (ys[i] - ym);
  }
  const double slope = sty / stt, icpt = ym - slope * tm;
  double sse = 0;
  for (int i = 0; i < fit.points; ++i) {
    const double r = ys[i] - icpt - slope * ts[i];
    sse += r * r;
  }
  const double se = std::sqrt(sse / std::max(n - 2.0, 1.0) / stt);
  fit.recovery_time_s = -1.0 / slope;
  fit.recovery_time_err_s = se / (slope * slope);
  fit.m0 = std::exp(icpt);
  fit.window_start_s = ts.front();
  fit.window_end_s = ts.back();
  fit.valid = slope < 0;
  return fit;
}

RecoveryFit fit_recovery_free_limit(const std::vector<double>& t,
                                    const std::vector<double>& lambda) {
  double lmin = std::numeric_limits<double>::infinity();
  for (double l : lambda) lmin = std::min(lmin, l);
  auto sse = [&](double linf, RecoveryFit& f) {
    f = fit_recovery(t, lambda, linf, 0.0);
    if (!f.valid) return std::numeric_limits<double>::infinity();
    double s = 0;
    for (size_t i = 0; i < t.size(); ++i) {
      const double m = f.m0 * std::exp(-t[i] / f.recovery_time_s);
      const double model = linf * (1 + m) / (1 - m);
      s += (model - lambda[i]) * (model - lambda[i]);
    }
    return s;
  };
  RecoveryFit best;
  double best_sse = std::numeric_limits<double>::infinity();
  const int grid = 2000;
  for (int k = 0; k < grid; ++k) {
    const double linf = 1.0 + (lmin - 1.0) * k / grid;
    RecoveryFit f;
    const double s = sse(linf, f);
    if (s < best_sse) {
      best_sse = s;
      best = f;
    }
  }
  return best;
}

TrajectorySample measure_discrete(const Network& net, double force_pN, const DynamicsState& s) {
  TrajectorySample t;
  LoadState plain;
  plain.force_pN = force_pN;
  EnergyBreakdown parts;
  network_energy(net, s.x, plain, nullptr, &parts);
  t.energy_pNum = parts.total() - parts.constraints;
  const Diameters d = measure_diameters(s.x);
  t.axial_um = d.axial_um;
  t.transverse_um = d.transverse_um;
  t.area_drift = (total_area(s.x, net.topo) - net.area0_um2) / net.area0_um2;
  t.volume_drift = (enclosed_volume(s.x, net.topo) - net.volume0_um3) / net.volume0_um3;
  return t;
}

}  // namespace rbc
