#include "discrete/stretch.hpp"

#include <chrono>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/CholmodSupport>

#include "core/geometry.hpp"
#include "discrete/hessian_approximation.hpp"

namespace rbc {

StretchPoint solve_equilibrium(const Network& net, double force_pN, Positions& x,
                               ConstraintMultipliers& lambda, const StretchOptions& opt,
                               const ProgressSink& progress) {
  const auto start = std::chrono::steady_clock::now();
  StretchPoint pt;
  pt.force_pN = force_pN;
  pt.vertices = net.topo.num_vertices;
  const int n = net.topo.num_vertices;
  LoadState load;
  load.force_pN = force_pN;
  Eigen::VectorXd u = flat(x);
  LbfgsOptions lo = opt.minimiser;
  if (lo.max_step <= 0) lo.max_step = 0.25 * net.lbar_um.minCoeff();
  // Preconditioner: P = approximate_hessian + the penalties' rank-2 part U K U^T,
  // U = [dA/dx, dV/dx], K = diag(kA, kV), applied by Sherman-Morrison-Woodbury:
  // (P + U K U^T)^{-1} v = P^{-1} v - Z (K^{-1} + U^T Z)^{-1} Z^T v, Z = P^{-1} U.
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> factor;
  Eigen::MatrixXd z;
  Eigen::Matrix2d utz;
  bool factored = false;
  if (n >= opt.precondition_min_vertices) {
    factor.compute(approximate_hessian(net, x));
    factored = factor.info() == Eigen::Success;
    if (factored) {
      Positions ga = Positions::Zero(3, n), gv = Positions::Zero(3, n);
      ConstraintParameters unit;
      unit.area_stiffness_pN_per_um3 = unit.volume_stiffness_pN_per_um5 = 1.0;
      constraint_energy(x, net.topo, net.area0_um2, net.volume0_um3, unit, {1.0, 0.0}, &ga);
      constraint_energy(x, net.topo, net.area0_um2, net.volume0_um3, unit, {0.0, 1.0}, &gv);
      // With unit multipliers and the state at x, the gradients are dA/dx + (A - A0) dA/dx;
      // rescale to the pure constraint gradients.
      const double da = total_area(x, net.topo) - net.area0_um2;
      const double dv = enclosed_volume(x, net.topo) - net.volume0_um3;
      Eigen::MatrixXd u(3 * n, 2);
      u.col(0) = flat(ga) / (1.0 + da);
      u.col(1) = flat(gv) / (1.0 + dv);
      z = factor.solve(u);
      utz = u.transpose() * z;
    } else {
      report(progress, "  preconditioner factorisation failed; using plain L-BFGS");
    }
  }
  auto set_preconditioner = [&](double stiffness_scale) {
    if (!factored) return;
    Eigen::Matrix2d m = utz;
    m(0, 0) += 1.0 / (stiffness_scale * net.constraints.area_stiffness_pN_per_um3);
    m(1, 1) += 1.0 / (stiffness_scale * net.constraints.volume_stiffness_pN_per_um5);
    const Eigen::Matrix2d m_inv = m.inverse();
    lo.precondition = [&factor, &z, m_inv](Eigen::VectorXd& v) {
      const Eigen::Vector2d ztv = z.transpose() * v;
      v = factor.solve(v);
      v -= z * (m_inv * ztv);
    };
  };
  MinimiserResult r;
  double previous_violation = std::numeric_limits<double>::infinity();
  for (int outer = 0; outer < opt.max_outer_iterations; ++outer) {
    load.multipliers = lambda;
    set_preconditioner(load.stiffness_scale);
    Objective f = [&](const Eigen::VectorXd& v, Eigen::VectorXd& g) {
      Positions p = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, n);
      Positions gp;
      const double e = network_energy(net, p, load, &gp);
      if (std::isfinite(e)) g = flat(gp);
      return e;
    };
    r = minimise_lbfgs(f, u, lo);
    pt.iterations += r.iterations;
    Eigen::Map<const Eigen::Matrix3Xd> p(u.data(), 3, n);
    const double a = total_area(p, net.topo), v = enclosed_volume(p, net.topo);
    pt.area_drift = (a - net.area0_um2) / net.area0_um2;
    pt.volume_drift = (v - net.volume0_um3) / net.volume0_um3;
    std::ostringstream msg;
    msg << "  F = " << force_pN << " pN, update " << outer << ": " << r.iterations
        << " iterations, residual " << r.residual << " pN, dA/A = " << pt.area_drift
        << ", dV/V = " << pt.volume_drift;
    report(progress, msg.str());
    if (!r.converged() && r.status != MinimiserStatus::max_iterations) break;
    const bool held = std::abs(pt.area_drift) < net.constraints.tolerance &&
                      std::abs(pt.volume_drift) < net.constraints.tolerance;
    if (held && r.converged()) break;
    if (!r.converged()) break;
    // Standard augmented-Lagrangian schedule: update the multipliers; if the violation did
    // not fall by 4x since the last update, stiffen the penalty tenfold (the forces of a
    // small violation had dropped below the minimiser's force tolerance).
    lambda.area_pN_per_um +=
        load.stiffness_scale * net.constraints.area_stiffness_pN_per_um3 * (a - net.area0_um2);
    lambda.volume_pN_per_um2 +=
        load.stiffness_scale * net.constraints.volume_stiffness_pN_per_um5 * (v - net.volume0_um3);
    const double violation = std::max(std::abs(pt.area_drift), std::abs(pt.volume_drift));
    if (violation > 0.25 * previous_violation) load.stiffness_scale *= 10.0;
    previous_violation = violation;
  }
  x = Eigen::Map<const Eigen::Matrix3Xd>(u.data(), 3, n);
  const bool held = std::abs(pt.area_drift) < net.constraints.tolerance &&
                    std::abs(pt.volume_drift) < net.constraints.tolerance;
  pt.converged = r.converged() && held;
  pt.residual_pN = r.residual;
  pt.status = !r.converged() ? to_string(r.status)
              : held         ? "converged"
                             : "constraints not held after multiplier updates";
  LoadState plain;
  plain.force_pN = force_pN;
  EnergyBreakdown parts;
  network_energy(net, x, plain, nullptr, &parts);
  pt.energy_pNum = parts.total() - parts.constraints;
  const Diameters d = measure_diameters(x);
  pt.axial_um = d.axial_um;
  pt.transverse_um = d.transverse_um;
  pt.x = x;
  pt.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return pt;
}

std::vector<StretchPoint> run_stretch(const Network& net, const std::vector<double>& forces,
                                      const StretchOptions& opt, const ProgressSink& progress) {
  std::vector<StretchPoint> out;
  Positions x = net.rest;
  ConstraintMultipliers lambda;
  for (double f : forces) {
    out.push_back(solve_equilibrium(net, f, x, lambda, opt, progress));
    std::ostringstream msg;
    const auto& p = out.back();
    msg << "F = " << f << " pN: D_A = " << p.axial_um << " um, D_T = " << p.transverse_um
        << " um, " << p.iterations << " iterations, " << p.wall_s << " s, " << p.status;
    report(progress, msg.str());
  }
  return out;
}

}  // namespace rbc
