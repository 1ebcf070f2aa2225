// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/continuum_stretch.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "continuum/contact_load.hpp"
#include "continuum/surface_extent.hpp"
#include "core/geometry.hpp"
#include "core/validation.hpp"
#include "discrete/augmented_lagrangian.hpp"
#include "discrete/constraint_energy.hpp"

namespace rbc {

std::string to_string(ContinuumSolver s) {
  return s == ContinuumSolver::newton ? "newton" : "lbfgs";
}

std::string to_string(SymmetryCheckAt s) {
  return s == SymmetryCheckAt::every_force ? "every-force" : "highest-force";
}

std::string to_string(ContinuumLoad l) {
  return l == ContinuumLoad::vertex_patch ? "vertex-patch" : "exact-contact";
}

std::string to_string(ContinuumMeasure m) {
  return m == ContinuumMeasure::vertices ? "vertices" : "quadric-fit";
}

void ContinuumOptions::validate() const {
  newton.validate();
  require_integer_in_range("Newton iterations per force", max_iterations_per_force, 1,
                           kMaxIterations);
  require_finite_in_range("time budget per force (0 = none)", "s", time_budget_s, 0.0, kUnbounded,
                          Ends::closed_open);
  require_integer_in_range("force-increment bisections", max_bisections, 0, 30);
  lbfgs.validate();
  require_integer_in_range("L-BFGS multiplier updates", lbfgs_outer_iterations, 1, 10000);
  require_finite_in_range("L-BFGS area penalty stiffness", "pN/um^3", lbfgs_area_stiffness, 0.0,
                          kUnbounded);
  require_finite_in_range("L-BFGS volume penalty stiffness", "pN/um^5", lbfgs_volume_stiffness, 0.0,
                          kUnbounded);
  lbfgs_schedule.validate();
  require_finite_in_range("exact contact fraction", "", exact_contact_fraction, 0.0, 0.5,
                          Ends::open_open);
}

void ContinuumOptions::validate(const std::vector<double>& forces_pN) const {
  validate();
  for (double f : forces_pN) {
    if (beyond_documented_force_range)
      require_finite_in_range("force (continuum model)", "pN", f, 0.0, kUnbounded,
                              Ends::closed_open);
    else
      validate_continuum_force(f);
  }
}

NewtonResult solve_equilibrium_lbfgs(const ContinuumModel& model, double force_pN, Positions& x,
                                     ConstraintMultipliers& lambda,
                                     const ContinuumOptions& options) {
  AugmentedLagrangianProblem al;
  al.area0_um2 = model.area0_um2;
  al.volume0_um3 = model.volume0_um3;
  al.constraints.area_stiffness_pN_per_um3 = options.lbfgs_area_stiffness;
  al.constraints.volume_stiffness_pN_per_um5 = options.lbfgs_volume_stiffness;
  al.constraints.tolerance = options.newton.constraint_tolerance;
  const int n = static_cast<int>(x.cols());
  Eigen::VectorXd v = flat(x);
  al.minimise = [&](const ConstraintMultipliers& l, double scale) {
    ConstraintParameters cp = al.constraints;
    cp.area_stiffness_pN_per_um3 *= scale;
    cp.volume_stiffness_pN_per_um5 *= scale;
    const Objective f = [&](const Eigen::VectorXd& y, Eigen::VectorXd& g) {
      const Positions p = Eigen::Map<const Eigen::Matrix3Xd>(y.data(), 3, n);
      Positions gp;
      const double e = continuum_energy(model, p, force_pN, &gp);
      if (!std::isfinite(e)) return e;
      const double ec =
          constraint_energy(p, model.topo, model.area0_um2, model.volume0_um3, cp, l, &gp);
      g = flat(gp);
      return e + ec;
    };
    const MinimiserResult mr = minimise_lbfgs(f, v, options.lbfgs);
    if (mr.status != MinimiserStatus::infeasible_start)
      x = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, n);
    return mr;
  };
  al.measure = [&] {
    return ConstraintState{total_area(x, model.topo), enclosed_volume(x, model.topo)};
  };
  al.cancel = options.cancel;
  double scale = 1.0;
  const AugmentedLagrangianResult r = run_augmented_lagrangian(
      al, options.lbfgs_outer_iterations, options.lbfgs_schedule, lambda, scale);
  NewtonResult res;
  res.iterations = r.iterations;
  res.residual_pN = r.last.residual;
  res.area_drift = r.area_drift;
  res.volume_drift = r.volume_drift;
  res.energy_pNum = continuum_energy(model, x, force_pN);
  switch (r.stop) {
    case AugmentedLagrangianStop::converged:
      res.status = NewtonStatus::converged;
      break;
    case AugmentedLagrangianStop::minimiser_failed:
      res.status = newton_status(r.last.status);
      break;
    case AugmentedLagrangianStop::budget_spent:
    case AugmentedLagrangianStop::max_updates:
      res.status = NewtonStatus::max_iterations;
      break;
  }
  return res;
}

namespace {

/// Solves at `to` from the equilibrium at `from`; on failure, restores the start and goes
/// through the midpoint (depth-limited). Accumulates iterations and sub-steps.
/// Limits of one requested force: iterations left, deadline.
struct ForceBudget {
  int iterations_left = 0;
  int factorisations = 0;     ///< spent so far (Newton's, the symmetry check's)
  int krylov_iterations = 0;  ///< spent so far
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  bool exhausted() const {
    return iterations_left <= 0 || std::chrono::steady_clock::now() > deadline;
  }
};

ForceBudget make_budget(const ContinuumOptions& options) {
  ForceBudget b;
  b.iterations_left = options.max_iterations_per_force;
  if (options.time_budget_s > 0)
    b.deadline = std::chrono::steady_clock::now() +
                 std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                     std::chrono::duration<double>(options.time_budget_s));
  return b;
}

/// One solve at `to` from x, lambda within the budget.
NewtonResult solve_once(const ContinuumModel& model, NewtonSolver& newton, double to, Positions& x,
                        ConstraintMultipliers& lambda, const ContinuumOptions& options,
                        ForceBudget& budget, const ProgressSink& progress) {
  throw_if_cancelled(options.cancel);
  NewtonLimits limits;
  limits.max_iterations = std::max(budget.iterations_left, 0);
  limits.deadline = budget.deadline;
  const NewtonResult r = options.solver == ContinuumSolver::newton
                             ? newton.solve(to, x, lambda, progress, limits)
                             : solve_equilibrium_lbfgs(model, to, x, lambda, options);
  budget.iterations_left -= std::max(r.iterations, 1);
  budget.factorisations += r.factorisations + r.stability_factorisations;
  budget.krylov_iterations += r.krylov_iterations;
  return r;
}

/// x, lambda: the equilibrium at `from`; guess (optional): the first attempt's start (a
/// predictor). Sub-steps after a failure restart from the equilibrium, never from the guess.
NewtonResult solve_with_bisection(const ContinuumModel& model, NewtonSolver& newton, double from,
                                  double to, Positions& x, ConstraintMultipliers& lambda,
                                  const ContinuumOptions& options, int depth, int& substeps,
                                  int& iterations, ForceBudget& budget,
                                  const ProgressSink& progress, const Positions* guess = nullptr) {
  const Positions x0 = x;
  const ConstraintMultipliers l0 = lambda;
  if (guess) x = *guess;
  NewtonResult r = solve_once(model, newton, to, x, lambda, options, budget, progress);
  iterations += r.iterations;
  ++substeps;
  if (r.converged() || depth >= options.max_bisections || budget.exhausted()) {
    if (!r.converged() && budget.exhausted() && r.status != NewtonStatus::time_budget &&
        budget.iterations_left <= 0)
      r.status = NewtonStatus::max_iterations;
    return r;
  }
  x = x0;
  lambda = l0;
  const double mid = 0.5 * (from + to);
  {
    std::ostringstream m;
    m << "force " << to << " pN: " << to_string(r.status) << " (residual " << r.residual_pN
      << " pN); continuing through " << mid << " pN";
    report(progress, m.str());
  }
  const NewtonResult rm = solve_with_bisection(model, newton, from, mid, x, lambda, options,
                                               depth + 1, substeps, iterations, budget, progress);
  if (!rm.converged()) return rm;
  return solve_with_bisection(model, newton, mid, to, x, lambda, options, depth + 1, substeps,
                              iterations, budget, progress);
}

/// Exchanges the solver's main method with a kept one for the life of the scope (also when
/// the solve in it throws, e.g. Cancelled).
class SwappedMethod {
 public:
  SwappedMethod(NewtonSolver& solver, ShiftedNewton* kept) : solver_(solver), kept_(kept) {
    if (kept_) solver_.swap_method(*kept_);
  }
  ~SwappedMethod() {
    if (kept_) solver_.swap_method(*kept_);
  }
  SwappedMethod(const SwappedMethod&) = delete;
  SwappedMethod& operator=(const SwappedMethod&) = delete;

 private:
  NewtonSolver& solver_;
  ShiftedNewton* kept_;
};

/// The sweep over forces_pN (continuation from the rest shape, or warm from `warm`). kept
/// (optional; Newton with reuse_across_solves only): per force, a method holding a
/// factorisation at that force's last equilibrium (made there after a cold solve; after a warm
/// solve on it, the one that solve ended with). A warm force starts from its own.
std::vector<ContinuumStretchPoint> stretch_sweep(const ContinuumModel& model,
                                                 const std::vector<double>& forces_pN,
                                                 const ContinuumOptions& options,
                                                 const ProgressSink& progress,
                                                 const StretchState& warm, KeptMethods* kept) {
  options.validate(forces_pN);
  if (!warm.empty()) warm.check_matches(static_cast<int>(model.rest.cols()), forces_pN);
  NewtonOptions newton_options = options.newton;
  if (!newton_options.cancel) newton_options.cancel = options.cancel;
  std::unique_ptr<NewtonSolver> own_solver;
  if (kept && kept->solver && kept->solver->same_mesh(model))
    kept->solver->rebind(model);
  else if (kept)
    kept->solver = std::make_unique<NewtonSolver>(model, newton_options);
  else
    own_solver = std::make_unique<NewtonSolver>(model, newton_options);
  NewtonSolver& newton = kept ? *kept->solver : *own_solver;
  // SymmetryCheckAt::highest_force: the solves trust the symmetry; the highest force's
  // equilibrium is checked after the sweep.
  const bool check_highest =
      options.solver == ContinuumSolver::newton && options.newton.symmetry == Symmetry::mirror &&
      options.newton.symmetry_check && options.symmetry_check_at == SymmetryCheckAt::highest_force;
  newton.set_symmetry_check(options.newton.symmetry_check && !check_highest);
  if (kept) {
    // Methods kept under another symmetry reduction (another bead patch) do not apply.
    const std::vector<int>& group = newton.symmetry_group();
    if (kept->group != group) {
      for (auto& m : kept->per_force) m.reset();
      kept->group = group;
    }
  }
  Positions x = model.rest;
  ConstraintMultipliers lambda;
  double previous = 0.0;
  // Secant predictor from the last two converged equilibria (used when feasible).
  Positions x_before;
  double f_before = 0.0;
  bool have_secant = false;
  std::vector<ContinuumStretchPoint> out;
  for (size_t k = 0; k < forces_pN.size(); ++k) {
    const double f = forces_pN[k];
    const auto t0 = std::chrono::steady_clock::now();
    ContinuumStretchPoint p;
    p.force_pN = f;
    const Positions x_start = x;
    int substeps = 0;
    NewtonResult r;
    bool solved = false;
    ForceBudget budget = make_budget(options);
    bool own_method = false;
    std::optional<ShiftedNewton> kept_none;
    if (!warm.empty()) {
      Positions xw = warm.x[k];
      ConstraintMultipliers lw = warm.multipliers[k];
      // With a kept factorisation of this force (ContinuumSweepSolver), a chord step on it;
      // otherwise a fresh factorisation at the warm state: the previous force's is a poor start
      // so close to the answer (measured at 980 elements, 13 Mills forces, p + 1 %: 39 Newton
      // iterations against 52 with it, 13 factorisations either way).
      auto& slot = kept ? kept->per_force[k] : kept_none;
      own_method = slot && slot->has_factorisation();
      if (!own_method) newton.forget_factorisation();
      {
        // The force keeps its method; the solver goes on with the previous force's.
        const SwappedMethod swapped(newton, own_method ? &*slot : nullptr);
        r = solve_once(model, newton, f, xw, lw, options, budget, progress);
      }
      p.iterations += r.iterations;
      ++substeps;
      p.warm = true;
      solved = r.converged();
      if (solved) {
        x = xw;
        lambda = lw;
      } else {
        report(progress, "  warm start at " + std::to_string(f) + " pN: " + to_string(r.status) +
                             "; continuing from the previous force's equilibrium");
      }
    }
    if (!solved) {
      // The secant predictor extrapolates at most one previous increment: a longer
      // extrapolation (0 -> 38 -> 130 pN: 2.4 increments) started 5,120 elements at 35 %
      // area drift, and the Newton iterates diverged from there.
      Positions guess;
      bool use_guess = false;
      if (have_secant && previous != f_before) {
        const double ratio = std::min((f - previous) / (previous - f_before), 1.0);
        guess = x + ratio * (x - x_before);
        use_guess = std::isfinite(continuum_energy(model, guess, f));
      }
      r = solve_with_bisection(model, newton, previous, f, x, lambda, options, 0, substeps,
                               p.iterations, budget, progress, use_guess ? &guess : nullptr);
    }
    if (kept && !(own_method && solved)) {
      // The force keeps a factorisation at its equilibrium (the continuation's last one may
      // be of an early iterate, or of the previous force): the next run's chord steps there
      // then contract by about the parameter change per step. None for a force that did not
      // converge or whose equilibrium is not one of the main (symmetric) problem.
      auto& slot = kept->per_force[k];
      slot.reset();
      if (r.converged() && newton.factorise_at(f, x, lambda, &budget.factorisations))
        slot = newton.copy_method();
    }
    p.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    p.substeps = substeps;
    p.factorisations = budget.factorisations;
    p.krylov_iterations = budget.krylov_iterations;
    p.converged = r.converged();
    p.status = r.status;
    p.residual_pN = r.residual_pN;
    p.symmetry_order = r.symmetry_order;
    p.symmetry_broken = r.symmetry_broken;
    p.area_drift = r.area_drift;
    p.volume_drift = r.volume_drift;
    p.energy_pNum = r.energy_pNum;
    p.vertices = static_cast<int>(x.cols());
    p.elements = model.num_elements();
    p.multipliers = lambda;
    p.x = x;
    const Diameters d = options.measure == ContinuumMeasure::vertices
                            ? measure_diameters(x)
                            : surface_diameters(x, model.topo);
    p.axial_um = d.axial_um;
    p.transverse_um = d.transverse_um;
    if (options.element_fields) p.fields = element_fields(model, x);
    {
      std::ostringstream m;
      m << "F = " << f << " pN: D_A = " << p.axial_um << " um, D_T = " << p.transverse_um << " um, "
        << p.iterations << " iterations, " << to_string(p.status) << ", residual " << p.residual_pN
        << " pN, " << p.wall_s << " s";
      report(progress, m.str());
    }
    if (r.converged()) {
      x_before = x_start;
      f_before = previous;
      have_secant = true;
    } else {
      have_secant = false;
    }
    out.push_back(std::move(p));
    previous = f;  // after a failure, continue from the last feasible state; the point says so
  }
  if (check_highest) {
    // The highest force's converged symmetric equilibrium (a buckled start's full solve needs
    // no check).
    int top = -1;
    for (size_t k = 0; k < out.size(); ++k)
      if (out[k].converged && out[k].symmetry_order > 1 && !out[k].symmetry_broken &&
          (top < 0 || out[k].force_pN >= out[static_cast<size_t>(top)].force_pN))
        top = static_cast<int>(k);
    if (top >= 0) {
      auto& p = out[static_cast<size_t>(top)];
      throw_if_cancelled(options.cancel);
      const auto t0 = std::chrono::steady_clock::now();
      const SectorStability st = newton.check_symmetric_state(p.force_pN, p.x, p.multipliers);
      p.factorisations += st.factorisations;
      p.wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (!st.stable) {
        std::ostringstream m;
        m << "the symmetric equilibrium at F = " << p.force_pN << " pN is a saddle (sector "
          << st.unstable_character << "): the sweep again with every force checked";
        report(progress, m.str());
        ContinuumOptions every = options;
        every.symmetry_check_at = SymmetryCheckAt::every_force;
        std::vector<ContinuumStretchPoint> again =
            stretch_sweep(model, forces_pN, every, progress, warm, kept);
        for (size_t k = 0; k < again.size(); ++k) {  // both passes' work
          again[k].iterations += out[k].iterations;
          again[k].factorisations += out[k].factorisations;
          again[k].krylov_iterations += out[k].krylov_iterations;
          again[k].wall_s += out[k].wall_s;
        }
        return again;
      }
    }
  }
  return out;
}

/// The model the run solves: `model` itself, or with ContinuumLoad::exact_contact a copy
/// whose patch is the exactly integrated contact load (held in `own`, which must outlive the
/// run).
const ContinuumModel& loaded_model(const ContinuumModel& model, const ContinuumOptions& options,
                                   std::optional<ContinuumModel>& own) {
  if (options.load == ContinuumLoad::vertex_patch) return model;
  options.validate();
  own = model;
  own->patch = exact_contact_load(model.rest, model.topo, options.exact_contact_fraction).patch;
  return *own;
}

}  // namespace

std::vector<ContinuumStretchPoint> run_continuum_stretch(const ContinuumModel& model,
                                                         const std::vector<double>& forces_pN,
                                                         const ContinuumOptions& options,
                                                         const ProgressSink& progress) {
  std::optional<ContinuumModel> own;
  return stretch_sweep(loaded_model(model, options, own), forces_pN, options, progress,
                       StretchState{}, nullptr);
}

std::vector<ContinuumStretchPoint> run_continuum_stretch(const ContinuumModel& model,
                                                         const std::vector<double>& forces_pN,
                                                         const ContinuumOptions& options,
                                                         const ProgressSink& progress,
                                                         const StretchState& warm) {
  std::optional<ContinuumModel> own;
  return stretch_sweep(loaded_model(model, options, own), forces_pN, options, progress, warm,
                       nullptr);
}

StretchState stretch_state(const std::vector<ContinuumStretchPoint>& points) {
  return stretch_state_of(points);
}

ContinuumSweepSolver::ContinuumSweepSolver(const ContinuumOptions& options) : options_(options) {
  options_.validate();
}

std::vector<ContinuumStretchPoint> ContinuumSweepSolver::run(const ContinuumModel& model,
                                                             const std::vector<double>& forces_pN,
                                                             const ProgressSink& progress,
                                                             const StretchState& warm) {
  if (scene_.change_to(forces_pN, model.topo)) {
    kept_.per_force.clear();
    kept_.per_force.resize(forces_pN.size());
  }
  // Kept factorisations serve only Newton steps that start from them.
  const bool keeps =
      options_.solver == ContinuumSolver::newton && options_.newton.reuse_across_solves;
  // The kept solver holds no reference to a loaded copy between runs (NewtonSolver::same_mesh
  // compares its own copy of the mesh; each run rebinds it).
  std::optional<ContinuumModel> own;
  return stretch_sweep(loaded_model(model, options_, own), forces_pN, options_, progress, warm,
                       keeps ? &kept_ : nullptr);
}

}  // namespace rbc
