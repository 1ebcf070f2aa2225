#include "discrete/stretch.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

#include "core/geometry.hpp"
#include "discrete/augmented_lagrangian.hpp"

namespace rbc {

void StretchOptions::validate() const {
  require_finite_in_range("force tolerance", "pN", minimiser.force_tolerance, 0.0,
                          kMaxForceTolerance_pN);
  minimiser.validate();
  require_integer_in_range("augmented-Lagrangian updates per force", max_outer_iterations, 1,
                           10000);
  require_integer_in_range("preconditioner threshold (vertices)", precondition_min_vertices, 0,
                           std::numeric_limits<int>::max());
  require_finite_in_range("largest preconditioned force of a small network", "pN",
                          small_network_max_force_pN, -1.0, 1e9);
  require_integer_in_range("preconditioner refresh interval", refresh_interval, 0,
                           std::numeric_limits<int>::max());
  require_finite_in_range("plain L-BFGS step cap (shortest links)", "", plain_max_step_links, 0.0,
                          kUnbounded);
  require_finite_in_range("preconditioned step cap (shortest links)", "",
                          preconditioned_max_step_links, 0.0, kUnbounded);
  augmented_lagrangian.validate();
}

std::string to_string(StretchStatus s) {
  switch (s) {
    case StretchStatus::converged:
      return "converged";
    case StretchStatus::max_iterations:
      return "iteration limit reached";
    case StretchStatus::line_search_failed:
      return "line search failed";
    case StretchStatus::infeasible_start:
      return "infeasible starting point";
    case StretchStatus::time_budget:
      return "time budget exhausted";
    case StretchStatus::constraints_not_held:
      return "constraints not held after multiplier updates";
    case StretchStatus::factorisation_failed:
      return "factorisation failed";
  }
  return "unknown";
}

std::ostream& operator<<(std::ostream& os, StretchStatus s) {
  return os << to_string(s);
}

StretchStatus stretch_status(MinimiserStatus s) {
  switch (s) {
    case MinimiserStatus::converged:
      return StretchStatus::converged;
    case MinimiserStatus::max_iterations:
      return StretchStatus::max_iterations;
    case MinimiserStatus::line_search_failed:
      return StretchStatus::line_search_failed;
    case MinimiserStatus::infeasible_start:
      return StretchStatus::infeasible_start;
    case MinimiserStatus::factorisation_failed:
      return StretchStatus::factorisation_failed;
  }
  return StretchStatus::line_search_failed;
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

StretchPoint solve_equilibrium(const Network& net, double force_pN, Positions& x,
                               ConstraintMultipliers& lambda, const StretchOptions& opt,
                               const ProgressSink& progress) {
  return solve_equilibrium(net, force_pN, x, lambda, opt, progress, nullptr);
}

StretchPoint solve_equilibrium(const Network& net, double force_pN, Positions& x,
                               ConstraintMultipliers& lambda, const StretchOptions& opt,
                               const ProgressSink& progress, NewtonPreconditioner* shared) {
  const auto start = std::chrono::steady_clock::now();
  StretchPoint pt;
  pt.force_pN = force_pN;
  pt.vertices = net.topo.num_vertices;
  const int n = net.topo.num_vertices;
  LoadState load;
  load.force_pN = force_pN;
  Eigen::VectorXd u = flat(x);
  LbfgsOptions lo = opt.minimiser;
  // Preconditioner: factorised at the start of the force and again whenever L-BFGS stalls.
  std::unique_ptr<NewtonPreconditioner> owned;
  NewtonPreconditioner* pre = nullptr;
  if (preconditioned(opt, n, force_pN)) {
    if (!shared) owned = std::make_unique<NewtonPreconditioner>(net, opt.preconditioner);
    pre = shared ? shared : owned.get();
  }
  if (lo.max_step <= 0)
    lo.max_step = (pre ? opt.preconditioned_max_step_links : opt.plain_max_step_links) *
                  net.lbar_um.minCoeff();
  const int factorisations_before = pre ? pre->statistics().factorisations : 0;
  auto refresh = [&] {
    const Positions p = Eigen::Map<const Eigen::Matrix3Xd>(u.data(), 3, n);
    if (pre->refresh(p, lambda, load.stiffness_scale)) {
      lo.precondition = [pre](Eigen::VectorXd& v) { pre->apply(v); };
    } else {
      lo.precondition = nullptr;
      report(progress,
             "  preconditioner factorisation failed; plain L-BFGS until the next refresh");
    }
  };
  if (pre && pre->ready() && !opt.refactorise_at_force_start)
    lo.precondition = [pre](Eigen::VectorXd& v) { pre->apply(v); };
  else if (pre)
    refresh();

  Objective f = [&](const Eigen::VectorXd& v, Eigen::VectorXd& g) {
    Positions p = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, n);
    Positions gp;
    const double e = network_energy(net, p, load, &gp);
    if (std::isfinite(e)) g = flat(gp);
    return e;
  };
  // One minimisation at fixed multipliers; with a preconditioner it is restarted from a
  // fresh factorisation whenever refresh_interval iterations cut the residual < 10x.
  // Budgets of the whole force: minimiser.max_iterations over all updates and segments,
  // and the optional wall-clock budget (checked once per iteration).
  int used = 0;
  long long evaluations = 0;
  const long long evaluation_budget =
      static_cast<long long>(std::max(opt.evaluations_per_iteration_budget, 1)) *
      std::max(lo.max_iterations, 1);
  bool exhausted = false;
  const bool timed = opt.time_budget_s > 0;
  const auto deadline = start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                    std::chrono::duration<double>(timed ? opt.time_budget_s : 0.0));
  bool out_of_time = false;
  auto minimise = [&]() {
    MinimiserResult total;
    const int used_before = used;
    double reference = std::numeric_limits<double>::quiet_NaN();
    for (;;) {
      bool stalled = false;
      int since = 0;
      const bool refreshing = pre && opt.refresh_interval > 0;
      IterationMonitor monitor;
      if (refreshing || timed)
        monitor = [&](int, double, double residual) {
          if (timed && std::chrono::steady_clock::now() > deadline) {
            out_of_time = true;
            return false;
          }
          if (!refreshing) return true;
          if (std::isnan(reference)) reference = residual;
          if (++since >= opt.refresh_interval && residual > 0.1 * reference) {
            stalled = true;
            return false;
          }
          return true;
        };
      LbfgsOptions seg = lo;
      seg.max_iterations = std::max(lo.max_iterations - used, 0);
      seg.max_evaluations = std::max(evaluation_budget - evaluations, 1LL);
      total = minimise_lbfgs(f, u, seg, monitor);
      used += total.iterations;
      evaluations += total.evaluations;
      if (evaluations >= evaluation_budget) exhausted = true;
      if (!stalled || out_of_time || exhausted) break;
      reference = total.residual;
      std::ostringstream msg;
      msg << "  refactorising after " << used << " iterations, residual " << total.residual
          << " pN";
      report(progress, msg.str());
      refresh();
    }
    total.iterations = used - used_before;
    return total;
  };

  // Area and volume by the shared augmented-Lagrangian driver; each inner minimisation is
  // the (preconditioned, refreshed) L-BFGS above at the driver's multipliers and scale.
  AugmentedLagrangianProblem al;
  al.area0_um2 = net.area0_um2;
  al.volume0_um3 = net.volume0_um3;
  al.constraints = net.constraints;
  al.minimise = [&](const ConstraintMultipliers& l, double scale) {
    load.multipliers = l;
    load.stiffness_scale = scale;
    if (pre && pre->ready()) pre->set_stiffness_scale(load.stiffness_scale);
    return minimise();
  };
  al.measure = [&] {
    Eigen::Map<const Eigen::Matrix3Xd> p(u.data(), 3, n);
    return ConstraintState{total_area(p, net.topo), enclosed_volume(p, net.topo)};
  };
  al.budget_spent = [&] { return out_of_time || exhausted || used >= lo.max_iterations; };
  al.on_update = [&](int update, const MinimiserResult& r, double area_drift, double volume_drift) {
    std::ostringstream msg;
    msg << "  F = " << force_pN << " pN, update " << update << ": " << r.iterations
        << " iterations, residual " << r.residual << " pN, dA/A = " << area_drift
        << ", dV/V = " << volume_drift;
    report(progress, msg.str());
  };
  al.cancel = lo.cancel;
  const AugmentedLagrangianResult res = run_augmented_lagrangian(
      al, opt.max_outer_iterations, opt.augmented_lagrangian, lambda, load.stiffness_scale);
  const MinimiserResult& r = res.last;
  pt.iterations = res.iterations;
  pt.area_drift = res.area_drift;
  pt.volume_drift = res.volume_drift;
  x = Eigen::Map<const Eigen::Matrix3Xd>(u.data(), 3, n);
  pt.stiffness_scale = load.stiffness_scale;
  const bool held = res.held();
  pt.converged = r.converged() && held;
  pt.residual_pN = r.residual;
  pt.status = out_of_time      ? StretchStatus::time_budget
              : !r.converged() ? stretch_status(r.status)
              : held           ? StretchStatus::converged
                               : StretchStatus::constraints_not_held;
  if (pre) {
    const auto& s = pre->statistics();
    pt.factorisations = s.factorisations - factorisations_before;
    std::ostringstream msg;
    msg << "  preconditioner: " << pt.factorisations << " factorisations (" << s.failed_attempts
        << " indefinite attempts in all), |L| = " << s.factor_nonzeros
        << ", totals (wall / main-thread CPU): assembly " << s.assembly_s << " / "
        << s.assembly_cpu_s << " s, factorisation " << s.factorisation_s << " / "
        << s.factorisation_cpu_s << " s (analysis " << s.analysis_cpu_s << " s CPU), solves "
        << s.solve_s << " / " << s.solve_cpu_s << " s";
    report(progress, msg.str());
  }
  LoadState plain;
  plain.force_pN = force_pN;
  EnergyBreakdown parts;
  network_energy(net, x, plain, nullptr, &parts);
  pt.energy_pNum = parts.total() - parts.constraints;
  const Diameters d = measure_diameters(x);
  pt.axial_um = d.axial_um;
  pt.transverse_um = d.transverse_um;
  pt.x = x;
  pt.multipliers = lambda;
  pt.wall_s = seconds_since(start);
  return pt;
}

std::vector<StretchPoint> run_stretch(const Network& net, const std::vector<double>& forces,
                                      const StretchOptions& opt, const ProgressSink& progress) {
  return run_stretch(net, forces, opt, progress, StretchState{});
}

std::vector<StretchPoint> run_stretch(const Network& net, const std::vector<double>& forces,
                                      const StretchOptions& opt, const ProgressSink& progress,
                                      const StretchState& warm) {
  if (!warm.empty()) warm.check_matches(net.topo.num_vertices, forces);
  std::vector<StretchPoint> out;
  Positions x = net.rest;
  ConstraintMultipliers lambda;
  std::unique_ptr<NewtonPreconditioner> pre;
  if (std::any_of(forces.begin(), forces.end(),
                  [&](double f) { return preconditioned(opt, net.topo.num_vertices, f); }))
    pre = std::make_unique<NewtonPreconditioner>(net, opt.preconditioner);
  for (size_t k = 0; k < forces.size(); ++k) {
    throw_if_cancelled(opt.minimiser.cancel);
    const double f = forces[k];
    StretchPoint p;
    bool solved = false;
    if (!warm.empty()) {
      Positions xw = warm.x[k];
      ConstraintMultipliers lw = warm.multipliers[k];
      p = solve_equilibrium(net, f, xw, lw, opt, progress, pre.get());
      p.warm = true;
      solved = p.converged;
      if (solved) {
        x = xw;
        lambda = lw;
      } else {
        report(progress, "  warm start did not converge (" + to_string(p.status) +
                             "); solving from the previous force's equilibrium");
      }
    }
    if (!solved) {
      const int warm_iterations = p.iterations;
      const double warm_s = p.wall_s;
      p = solve_equilibrium(net, f, x, lambda, opt, progress, pre.get());
      p.iterations += warm_iterations;
      p.wall_s += warm_s;
    }
    std::ostringstream msg;
    msg << "F = " << f << " pN: D_A = " << p.axial_um << " um, D_T = " << p.transverse_um << " um, "
        << p.iterations << " iterations, " << p.wall_s << " s, " << p.status;
    report(progress, msg.str());
    if (opt.on_point) opt.on_point(p);
    out.push_back(std::move(p));
  }
  return out;
}

StretchState stretch_state(const std::vector<StretchPoint>& points) {
  return stretch_state_of(points);
}

}  // namespace rbc
