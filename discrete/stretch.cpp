// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/stretch.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "core/geometry.hpp"
#include "core/reduced_problem.hpp"
#include "core/symmetry_stability.hpp"
#include "discrete/augmented_lagrangian.hpp"
#include "discrete/tweezers.hpp"

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

void StretchOptions::validate(const std::vector<double>& forces_pN) const {
  validate();
  for (double f : forces_pN) {
    if (beyond_documented_force_range)
      require_finite_in_range("force (discrete model)", "pN", f, 0.0, kUnbounded,
                              Ends::closed_open);
    else
      validate_discrete_force(f);
  }
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

/// A state farther than this (um, any coordinate) from its symmetric part is not symmetric
/// (the default rest meshes are symmetric to 4e-10 um).
constexpr double kSymmetricUm = 1e-6;

/// Largest coordinate distance (um) of x from its symmetric part under a reduction.
double asymmetry_um(const SymmetryReduction& r, const Positions& x) {
  return (expand(r, symmetric_part(r, flat(x))) - flat(x)).cwiseAbs().maxCoeff();
}

Positions positions_of(const Eigen::VectorXd& v, int n) {
  return Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, n);
}

/// Prepared state of one network's stretch, shared by the forces of a run: the Newton
/// preconditioners of the full and (Symmetry::mirror) the reduced problem, each built when
/// first needed (their symbolic analyses are done once), and the scene's mirror group with its
/// reduction, the exact Hessian and the sector check of the symmetric equilibria.
class StretchWorkspace {
 public:
  /// shared: a full-problem preconditioner of net to use (nullptr: one is built when needed).
  StretchWorkspace(const Network& net, const StretchOptions& opt, NewtonPreconditioner* shared)
      : net_(net), opt_(opt), shared_(shared) {
    if (opt.symmetry != Symmetry::mirror) return;
    const MeshSymmetry g = tweezers_scene_symmetry(net.rest, net.topo, net.patch);
    if (g.order() == 1) return;  // the full problem, computed as with Symmetry::none
    reduction_ = std::make_shared<const SymmetryReduction>(make_symmetry_reduction(g));
    if (opt.symmetry_check) {
      SparseCholeskyOptions co;
      co.ordering = opt.preconditioner.ordering;
      co.supernodal_min_unknowns = opt.preconditioner.supernodal_min_unknowns;
      co.blas_threads = opt.preconditioner.blas_threads;
      stability_ = std::make_unique<SymmetryStabilityCheck>(g, co);
    }
  }

  /// The reduction of the scene's mirror group (null: the full problem).
  const std::shared_ptr<const SymmetryReduction>& reduction() const { return reduction_; }

  /// Until reset (nullptr), preconditioner() of p's kind (full or reduced) returns p: a
  /// preconditioner kept for this force by a StretchSweepSolver.
  void use_for_this_force(NewtonPreconditioner* p) { override_ = p; }
  /// Whether p is the preconditioner kept for this force.
  bool is_kept(const NewtonPreconditioner* p) const { return p && p == override_; }

  /// The preconditioner of the full or the reduced problem.
  NewtonPreconditioner* preconditioner(bool reduced) {
    if (override_ && override_->reduced() == reduced) return override_;
    if (reduced) {
      if (!reduced_pre_)
        reduced_pre_ =
            std::make_unique<NewtonPreconditioner>(net_, opt_.preconditioner, reduction_);
      return reduced_pre_.get();
    }
    if (shared_) return shared_;
    if (!full_pre_) full_pre_ = std::make_unique<NewtonPreconditioner>(net_, opt_.preconditioner);
    return full_pre_.get();
  }

  bool checking() const { return static_cast<bool>(stability_); }

  /// The sector check at a symmetric equilibrium x (force F) of the augmented Lagrangian at
  /// multipliers lambda and penalty scale s: the exact network Hessian with the constraints'
  /// curvature (sigma d2A + p d2V, sigma = lambda_A + s k_A (A - A0), p likewise); the
  /// penalty's rank-two part s k dA dA' has symmetric gradients, so it vanishes on the
  /// non-trivial sectors. The rigid turns about x and z lie in a non-trivial sector of the
  /// four-mirror group, and the residual makes their zero curvature slightly negative
  /// (turn_residual_curvature): the Hessian is shifted by twice that curvature (a multiple of
  /// the identity, which shifts every curvature per um^2 by the same amount), so a turn does not
  /// count as buckling while a shape change does.
  SectorStability check(const Positions& x, double force_pN, const ConstraintMultipliers& lambda,
                        double scale) {
    // The exact Hessian goes into the reduced preconditioner's matrix (same network, already
    // built, or the one kept for this force, rebound to this network; its factorisation does
    // not read the values again) unless that one drops the two-ring pairs.
    NetworkHessian* exact = nullptr;
    if (opt_.preconditioner.hessian.bending_coupling == BendingCoupling::two_ring) {
      exact = &preconditioner(true)->hessian();
    } else {
      if (!exact_) {
        NetworkHessianOptions o = opt_.preconditioner.hessian;
        o.bending_coupling = BendingCoupling::two_ring;
        exact_ = std::make_unique<NetworkHessian>(net_, o);
      }
      exact = exact_.get();
    }
    const ConstraintParameters& k = net_.constraints;
    ConstraintCurvature cc;
    cc.tension_pN_per_um = lambda.area_pN_per_um + scale * k.area_stiffness_pN_per_um3 *
                                                       (total_area(x, net_.topo) - net_.area0_um2);
    cc.pressure_pN_per_um2 =
        lambda.volume_pN_per_um2 +
        scale * k.volume_stiffness_pN_per_um5 * (enclosed_volume(x, net_.topo) - net_.volume0_um3);
    LoadState load;
    load.force_pN = force_pN;
    load.multipliers = lambda;
    load.stiffness_scale = scale;
    Positions r;
    const double allowance = std::isfinite(network_energy(net_, x, load, &r))
                                 ? 2.0 * rigid_turn_residual_curvature(x, r)
                                 : 0.0;
    return stability_->check(exact->assemble_exact(x, cc, allowance), kSectorShift);
  }

  /// The push off an unstable symmetric state: a unit vector of the sector (3N).
  Eigen::VectorXd sector_direction(int character) const {
    return stability_->sector_direction(character, 1);
  }

 private:
  const Network& net_;
  const StretchOptions& opt_;
  NewtonPreconditioner* shared_ = nullptr;
  NewtonPreconditioner* override_ = nullptr;
  std::unique_ptr<NewtonPreconditioner> full_pre_, reduced_pre_;
  std::shared_ptr<const SymmetryReduction> reduction_;
  std::unique_ptr<SymmetryStabilityCheck> stability_;
  std::unique_ptr<NetworkHessian> exact_;  ///< only for a one-ring preconditioner
};

/// One force from x (updated in place), carrying the multipliers along: L-BFGS (preconditioned
/// by `pre` unless null) with the augmented-Lagrangian updates, on all 3N coordinates or, with
/// a reduction, on q with x = P q (x must then be symmetric; its symmetric part is the start).
/// kept_start: pre is a preconditioner kept for this force (StretchSweepSolver): start on its
/// factorisation whatever refactorise_at_force_start says.
StretchPoint minimise_force(const Network& net, double force_pN, Positions& x,
                            ConstraintMultipliers& lambda, const StretchOptions& opt,
                            const ProgressSink& progress, NewtonPreconditioner* pre,
                            const std::shared_ptr<const SymmetryReduction>& red,
                            bool kept_start = false) {
  const auto start = std::chrono::steady_clock::now();
  StretchPoint pt;
  pt.force_pN = force_pN;
  pt.vertices = net.topo.num_vertices;
  const int n = net.topo.num_vertices;
  LoadState load;
  load.force_pN = force_pN;
  // The unknowns: x, or q of x = P q.
  Eigen::VectorXd u = red ? symmetric_part(*red, flat(x)) : Eigen::VectorXd(flat(x));
  auto positions = [&] { return positions_of(red ? expand(*red, u) : u, n); };
  LbfgsOptions lo = opt.minimiser;
  // Preconditioner: factorised at the start of the force and again whenever L-BFGS stalls.
  if (lo.max_step <= 0)
    lo.max_step = (pre ? opt.preconditioned_max_step_links : opt.plain_max_step_links) *
                  net.lbar_um.minCoeff();
  // Reduced: the tolerance and the step cap measure full per-vertex forces and displacements.
  if (red) lo = reduce_lbfgs_options(lo, red);
  const int factorisations_before = pre ? pre->statistics().factorisations : 0;
  auto refresh = [&] {
    const Positions p = positions();
    if (pre->refresh(p, lambda, load.stiffness_scale)) {
      lo.precondition = [pre](Eigen::VectorXd& v) { pre->apply(v); };
    } else {
      lo.precondition = nullptr;
      report(progress,
             "  preconditioner factorisation failed; plain L-BFGS until the next refresh");
    }
  };
  if (pre && pre->ready() && (kept_start || !opt.refactorise_at_force_start))
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
  if (red) f = reduce_objective(std::move(f), red);  // f(P q), gradient P' grad f
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
    if (red) {
      const Positions p = positions();
      return ConstraintState{total_area(p, net.topo), enclosed_volume(p, net.topo)};
    }
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
  x = positions();
  pt.stiffness_scale = load.stiffness_scale;
  const bool held = res.held();
  pt.converged = r.converged() && held;
  pt.residual_pN = r.residual;
  if (red) {
    // The full problem's largest net vertex force at P q, at the last minimisation's
    // multipliers and scale (equal to the reduced one's per-vertex force up to the rest
    // mesh's asymmetry).
    Positions g;
    if (std::isfinite(network_energy(net, x, load, &g)))
      pt.residual_pN = g.colwise().norm().maxCoeff();
  }
  pt.status = out_of_time      ? StretchStatus::time_budget
              : !r.converged() ? stretch_status(r.status)
              : held           ? StretchStatus::converged
                               : StretchStatus::constraints_not_held;
  if (pre) {
    const auto& s = pre->statistics();
    pt.factorisations = s.factorisations - factorisations_before;
    std::ostringstream msg;
    msg << "  preconditioner: " << pt.factorisations << " factorisations (" << s.failed_attempts
        << " indefinite attempts in all), |L| = " << s.factor_nonzeros;
    if (red) msg << " (" << s.unknowns << " of " << 3 * n << " unknowns: mirror-reduced)";
    msg << ", totals (wall / main-thread CPU): assembly " << s.assembly_s << " / "
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

/// One force with the workspace's preconditioners and symmetry: the full problem (no
/// reduction, or a start that is not symmetric), or the reduced one followed by the sector
/// check and, at a saddle, a full solve from the pushed state.
StretchPoint solve_force(StretchWorkspace& ws, const Network& net, double force_pN, Positions& x,
                         ConstraintMultipliers& lambda, const StretchOptions& opt,
                         const ProgressSink& progress) {
  const bool pre = preconditioned(opt, net.topo.num_vertices, force_pN);
  const std::shared_ptr<const SymmetryReduction>& red = ws.reduction();
  if (!red) {
    NewtonPreconditioner* p = pre ? ws.preconditioner(false) : nullptr;
    return minimise_force(net, force_pN, x, lambda, opt, progress, p, nullptr, ws.is_kept(p));
  }
  const auto start = std::chrono::steady_clock::now();
  const bool symmetric = asymmetry_um(*red, x) <= kSymmetricUm;
  if (!symmetric) report(progress, "  start not mirror-symmetric: solving without the symmetry");
  NewtonPreconditioner* first = pre ? ws.preconditioner(symmetric) : nullptr;
  StretchPoint pt = minimise_force(net, force_pN, x, lambda, opt, progress, first,
                                   symmetric ? red : nullptr, ws.is_kept(first));
  if (symmetric) {
    pt.symmetry_order = red->group_order;
    if (pt.converged && ws.checking()) {
      const auto check_start = std::chrono::steady_clock::now();
      const SectorStability st = ws.check(pt.x, force_pN, pt.multipliers, pt.stiffness_scale);
      std::ostringstream msg;
      msg << "  mirror symmetry check: " << st.factorisations << " sector factorisations, "
          << seconds_since(check_start) << " s: "
          << (st.stable ? "stable"
                        : "unstable in sector " + std::to_string(st.unstable_character) +
                              ", solving without the symmetry");
      report(progress, msg.str());
      if (!st.stable) {
        // A saddle: pushed off along the unstable sector and solved in full, within what is
        // left of the force's iteration and time budgets.
        const Eigen::VectorXd push = ws.sector_direction(st.unstable_character);
        flat(x) += (kSymmetryPushUm / push.cwiseAbs().maxCoeff()) * push;
        StretchOptions rest = opt;
        rest.minimiser.max_iterations = std::max(opt.minimiser.max_iterations - pt.iterations, 1);
        if (opt.time_budget_s > 0)
          rest.time_budget_s = std::max(opt.time_budget_s - seconds_since(start), 1e-9);
        StretchPoint full = minimise_force(net, force_pN, x, lambda, rest, progress,
                                           pre ? ws.preconditioner(false) : nullptr, nullptr);
        full.iterations += pt.iterations;
        full.factorisations += pt.factorisations;
        pt = std::move(full);
        pt.symmetry_order = 1;
      }
    }
  }
  pt.symmetry_broken = asymmetry_um(*red, pt.x) > kSymmetricUm;
  pt.wall_s = seconds_since(start);
  return pt;
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
  opt.validate({force_pN});
  StretchWorkspace ws(net, opt, shared);
  return solve_force(ws, net, force_pN, x, lambda, opt, progress);
}

std::vector<StretchPoint> run_stretch(const Network& net, const std::vector<double>& forces,
                                      const StretchOptions& opt, const ProgressSink& progress) {
  return run_stretch(net, forces, opt, progress, StretchState{});
}

namespace {

/// Whether a and b (either may be null: the full problem) map x = P q alike.
bool same_reduction(const SymmetryReduction* a, const SymmetryReduction* b) {
  if (!a || !b) return !a && !b;
  return a->group_order == b->group_order && a->reduced_index == b->reduced_index &&
         a->sign == b->sign;
}

/// Clears the workspace's per-force preconditioner when the scope ends (also on a throw).
struct ForcePreconditioner {
  StretchWorkspace& ws;
  ForcePreconditioner(StretchWorkspace& w, NewtonPreconditioner* p) : ws(w) {
    ws.use_for_this_force(p);
  }
  ~ForcePreconditioner() { ws.use_for_this_force(nullptr); }
  ForcePreconditioner(const ForcePreconditioner&) = delete;
  ForcePreconditioner& operator=(const ForcePreconditioner&) = delete;
};

/// The sweep (continuation from rest, or warm from `warm`). kept (optional, one entry per
/// force): a preconditioner factorised at an equilibrium of that force; a warm force starts
/// from its own (no refactorisation at the force start) and leaves it as it is; any other
/// converged force leaves one factorised at its equilibrium.
std::vector<StretchPoint> stretch_sweep(const Network& net, const std::vector<double>& forces,
                                        const StretchOptions& opt, const ProgressSink& progress,
                                        const StretchState& warm,
                                        std::vector<std::unique_ptr<NewtonPreconditioner>>* kept) {
  opt.validate(forces);
  if (!warm.empty()) warm.check_matches(net.topo.num_vertices, forces);
  std::vector<StretchPoint> out;
  Positions x = net.rest;
  ConstraintMultipliers lambda;
  // One workspace for the run: the preconditioners' analyses and the symmetry are done once.
  StretchWorkspace ws(net, opt, nullptr);
  for (size_t k = 0; k < forces.size(); ++k) {
    throw_if_cancelled(opt.minimiser.cancel);
    const double f = forces[k];
    const bool pre = preconditioned(opt, net.topo.num_vertices, f);
    StretchPoint p;
    bool solved = false, own = false;
    if (!warm.empty()) {
      Positions xw = warm.x[k];
      ConstraintMultipliers lw = warm.multipliers[k];
      NewtonPreconditioner* mine = kept && pre ? (*kept)[k].get() : nullptr;
      if (mine) {
        // Of the kind solve_force picks for this start (reduced for a symmetric one).
        const bool symmetric = ws.reduction() && asymmetry_um(*ws.reduction(), xw) <= kSymmetricUm;
        // ... and of this workspace's reduction (another bead patch may keep another group).
        own = mine->ready() && mine->reduced() == symmetric &&
              (!symmetric || same_reduction(mine->reduction(), ws.reduction().get()));
        if (own) {
          try {
            mine->rebind(net);
          } catch (const std::invalid_argument&) {  // another bending law, custom terms
            own = false;
          }
        }
      }
      {
        const ForcePreconditioner use(ws, own ? mine : nullptr);
        p = solve_force(ws, net, f, xw, lw, opt, progress);
      }
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
      p = solve_force(ws, net, f, x, lambda, opt, progress);
      p.iterations += warm_iterations;
      p.wall_s += warm_s;
    }
    // A warm solve on the kept preconditioner leaves it as it is (refactorised only where
    // L-BFGS stalled), unless it ended off its kind (a saddle left for a buckled state).
    const bool p_symmetric =
        kept && ws.reduction() && asymmetry_um(*ws.reduction(), p.x) <= kSymmetricUm;
    if (kept && !(own && solved && (*kept)[k]->reduced() == p_symmetric)) {
      // The force keeps a preconditioner factorised at its equilibrium (the one of the solve
      // was made at the force's start): the next run's L-BFGS starts Newton-like there.
      auto& slot = (*kept)[k];
      slot.reset();
      if (p.converged && pre) {
        slot = std::make_unique<NewtonPreconditioner>(
            net, opt.preconditioner,
            p_symmetric ? ws.reduction() : std::shared_ptr<const SymmetryReduction>());
        const int before = slot->statistics().factorisations;
        if (!slot->refresh(p.x, p.multipliers, p.stiffness_scale))
          slot.reset();
        else
          p.factorisations += slot->statistics().factorisations - before;
      }
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

}  // namespace

std::vector<StretchPoint> run_stretch(const Network& net, const std::vector<double>& forces,
                                      const StretchOptions& opt, const ProgressSink& progress,
                                      const StretchState& warm) {
  return stretch_sweep(net, forces, opt, progress, warm, nullptr);
}

StretchSweepSolver::StretchSweepSolver(const StretchOptions& options) : options_(options) {
  options_.validate();
}

std::vector<StretchPoint> StretchSweepSolver::run(const Network& net,
                                                  const std::vector<double>& forces_pN,
                                                  const ProgressSink& progress,
                                                  const StretchState& warm) {
  if (scene_.change_to(forces_pN, net.topo)) {
    kept_.clear();
    kept_.resize(forces_pN.size());
  }
  // A model with custom terms cannot be rebound (NetworkHessian::rebind): nothing to keep.
  const bool keeps = !has_term(net, TermKind::custom);
  return stretch_sweep(net, forces_pN, options_, progress, warm, keeps ? &kept_ : nullptr);
}

StretchState stretch_state(const std::vector<StretchPoint>& points) {
  return stretch_state_of(points);
}

}  // namespace rbc
