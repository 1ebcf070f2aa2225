// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/newton_solver.hpp"

#include "core/blas_threads.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "core/lbfgs.hpp"
#include "core/reduced_problem.hpp"
#include "core/validation.hpp"

namespace rbc {

void NewtonOptions::validate() const {
  // Above 10 pN a force tolerance no longer resolves the smallest Mills force (16 pN).
  require_finite_in_range("force tolerance", "pN", force_tolerance_pN, 0.0, 10.0);
  require_finite_in_range("relative area/volume tolerance", "", constraint_tolerance, 0.0, 1.0,
                          Ends::open_open);
  require_integer_in_range("max iterations", max_iterations, 1, kMaxIterations);
  require_integer_in_range("line-search halvings", max_line_search, 1, 1000);
  require_integer_in_range("factorisation reuse", max_factor_reuse, 0, 1000);
  require_finite_in_range("reuse contraction", "", reuse_contraction, 0.0, 1.0, Ends::open_open);
  // A step larger than 10 um (the cell's size) is no cap at all.
  require_finite_in_range("Newton largest step", "um", max_step_um, 0.0, 10.0);
  require_finite_in_range("merit penalty", "pN um", penalty_pNum, 0.0, kUnbounded,
                          Ends::closed_open);
  require_integer_in_range("Newton BLAS threads (0 = OpenBLAS default)", blas_threads, 0, 1024);
  require_integer_in_range("Newton Krylov correction iterations (0 = off)", krylov_iterations, 0,
                           100000);
  require_finite_in_range("Newton Krylov correction tolerance", "", krylov_tolerance, 0.0, 1.0,
                          Ends::open_open);
  require_integer_in_range("Newton Krylov refactorisation iterations", krylov_refactor_iterations,
                           0, 100000);
  require_finite_in_range("Newton Krylov initial shift", "", krylov_initial_shift, 0.0, 1.0,
                          Ends::closed_closed);
  require_integer_in_range("Newton Krylov factorisation reuse", krylov_max_factor_reuse, 0, 1000);
  require_integer_in_range("Newton Krylov lagged-correction iterations (0 = krylov_iterations)",
                           krylov_lagged_iterations, 0, 100000);
  require_integer_in_range("Newton supernodal threshold (unknowns)", supernodal_min_unknowns, 0,
                           std::numeric_limits<int>::max());
}

double largest_vertex_norm(const Positions& v) {
  return v.cols() ? v.colwise().norm().maxCoeff() : 0.0;
}

ShiftedNewtonOptions shifted_newton_options(const NewtonOptions& o) {
  ShiftedNewtonOptions c;
  c.force_tolerance = o.force_tolerance_pN;
  c.constraint_tolerance = o.constraint_tolerance;
  c.max_iterations = o.max_iterations;
  c.block_size = 3;
  c.max_step = o.max_step_um;
  c.max_line_search = o.max_line_search;
  c.penalty = o.penalty_pNum;
  c.max_factor_reuse = o.max_factor_reuse;
  c.reuse_contraction = o.reuse_contraction;
  c.reuse_across_calls = o.reuse_across_solves;
  c.krylov_iterations = o.krylov_iterations;
  c.krylov_tolerance = o.krylov_tolerance;
  c.krylov_refactor_iterations = o.krylov_refactor_iterations;
  c.krylov_lagged_hessian = o.krylov_lagged_hessian;
  c.krylov_exact_when_far = o.krylov_exact_when_far;
  c.krylov_lagged_iterations = o.krylov_lagged_iterations;
  c.krylov_lagged_constraints = o.krylov_lagged_constraints;
  if (o.krylov_iterations > 0) {
    c.initial_shift = o.krylov_initial_shift;
    c.max_factor_reuse = o.krylov_max_factor_reuse;
  }
  c.shift_scale = ShiftScale::mean_abs_diagonal;
  c.cholesky.ordering = o.ordering;
  c.cholesky.supernodal_min_unknowns = o.supernodal_min_unknowns;
  c.cholesky.blas_threads = o.blas_threads;
  // A float factor only where the Krylov correction makes every step exact on the double d2L:
  // with an initial shift at or below the kept one (calibrate's forward model, 1e-8) the
  // lagged chord steps skip the correction, being exact already for a double factor.
  c.cholesky.solve_precision = o.krylov_iterations > 0 && c.initial_shift > c.krylov_kept_shift
                                   ? o.factor_precision
                                   : SolvePrecision::double_precision;
  c.cancel = o.cancel;
  return c;
}

namespace {

/// Unnormalised face normal (b - a) x (c - a) of face f of a flat 3N layout.
Vec3 face_normal(const Eigen::VectorXd& x, const Topology& topo, int f) {
  const auto t = topo.faces.col(f);
  const Vec3 a = x.segment<3>(3 * t(0));
  return (Vec3(x.segment<3>(3 * t(1))) - a).cross(Vec3(x.segment<3>(3 * t(2))) - a);
}

}  // namespace

bool any_face_flipped(const Eigen::VectorXd& from, const Eigen::VectorXd& to,
                      const Topology& topo) {
  for (int f = 0; f < topo.num_faces(); ++f)
    if (face_normal(to, topo, f).dot(face_normal(from, topo, f)) <= 0.0) return true;
  return false;
}

NewtonSolver::NewtonSolver(const ContinuumModel& model, const NewtonOptions& options)
    : model_(&model),
      mesh_rest_(model.rest),
      mesh_faces_(model.topo.faces),
      options_((options.validate(), options)),
      newton_(shifted_newton_options(options)) {
  if (options.symmetry == Symmetry::mirror) {
    mesh_symmetry_ = find_mirror_symmetry(model.rest, model.topo);
    update_reduction();
  }
}

bool NewtonSolver::same_mesh(const ContinuumModel& model) const {
  // Against the solver's own copy: the model it was last bound to may be gone by now.
  return model.rest.cols() == mesh_rest_.cols() && model.topo.faces.cols() == mesh_faces_.cols() &&
         model.rest == mesh_rest_ && model.topo.faces == mesh_faces_;
}

void NewtonSolver::rebind(const ContinuumModel& model) {
  if (!same_mesh(model))
    throw std::invalid_argument(
        "NewtonSolver::rebind: the model's mesh (rest positions, faces) is not the solver's");
  model_ = &model;
  if (reduced_hessian_) reduced_hessian_->rebind(model);
  if (symmetric_energy_) symmetric_energy_->rebind(model);
  forget_factorisation();
}

NewtonProblem NewtonSolver::full_problem(double force_pN) {
  return continuum_newton_problem(*model_, force_pN, [this]() -> BlockHessian& {
    // Built at its first use, which the mirror path reaches only off the symmetric states.
    if (!hessian_) hessian_ = std::make_unique<BlockHessian>(model_->topo, BlockStorage::lower);
    return *hessian_;
  });
}

void NewtonSolver::update_reduction() {
  const MeshSymmetry g = keep_invariant(mesh_symmetry_, model_->patch.vertex, model_->patch.share,
                                        0, kTweezersShareTolerance);
  if (g.reflections == reduced_group_) return;
  // Built aside, then installed: a throw leaves the solver as it was (a kept solver outlives
  // the run, NewtonSolver::rebind).
  std::shared_ptr<const SymmetryReduction> reduction;
  std::shared_ptr<ReducedProblemCache> cache;
  std::unique_ptr<ReducedLagrangianHessian> hessian;
  std::shared_ptr<SymmetricContinuumEnergy> energy;
  if (g.order() > 1) {
    reduction = std::make_shared<const SymmetryReduction>(make_symmetry_reduction(g));
    cache = std::make_shared<ReducedProblemCache>();
    hessian = std::make_unique<ReducedLagrangianHessian>(*model_, g, *reduction);
    energy = std::make_shared<SymmetricContinuumEnergy>(*model_, *hessian);
  }
  if (reduction) {
    const Eigen::VectorXd rest = flat(model_->rest);
    rest_asymmetry_um_ =
        (expand(*reduction, symmetric_part(*reduction, rest)) - rest).cwiseAbs().maxCoeff();
  }
  reduction_ = std::move(reduction);
  reduced_cache_ = std::move(cache);
  reduced_hessian_ = std::move(hessian);
  symmetric_energy_ = std::move(energy);
  stability_.reset();
  newton_.forget_factorisation();  // of the other problem size
  if (g.order() > 1) reduced_group_symmetry_ = g;
  reduced_group_ = g.reflections;
}

namespace {

/// A rest mesh within this (um, any coordinate) of its symmetric part is symmetric to rounding:
/// the symmetric evaluation's energy, constraints and per-vertex forces are then the full
/// problem's to rounding (the forces differ by about the asymmetry times the stiffness: below
/// 1e-8 pN for stiffnesses up to 1e4 pN/um), and a reduced solve needs no full evaluation
/// unless its state is checked.
constexpr double kSymmetricMeshUm = 1e-12;

}  // namespace

NewtonProblem continuum_newton_problem(const ContinuumModel& model, double force_pN,
                                       BlockHessian& h, const ContinuumExtraTerms& extra) {
  return continuum_newton_problem(
      model, force_pN, [hp = &h]() -> BlockHessian& { return *hp; }, extra);
}

NewtonProblem continuum_newton_problem(const ContinuumModel& model, double force_pN,
                                       std::function<BlockHessian&()> storage,
                                       const ContinuumExtraTerms& extra) {
  const double a0 = model.area0_um2, v0 = model.volume0_um3;
  const auto n = static_cast<Eigen::Index>(model.rest.cols());
  // Scratch positions and gradient, shared by the callbacks (no allocation per evaluation).
  struct Scratch {
    Positions x, g;
  };
  auto s = std::make_shared<Scratch>(Scratch{Positions(3, n), Positions(3, n)});
  const ContinuumModel* m = &model;
  NewtonProblem pb;
  pb.evaluate = [=](const Eigen::VectorXd& xf, NewtonPoint& p) {
    flat(s->x) = xf;
    p.value = continuum_energy(*m, s->x, force_pN, &s->g);
    if (!std::isfinite(p.value)) return false;
    if (extra.energy) p.value += extra.energy(s->x, s->g);
    p.grad = flat(s->g);
    const ConstraintValues cv = evaluate_constraints(s->x, m->topo);
    p.c = Eigen::Vector2d(cv.area_um2 - a0, cv.volume_um3 - v0);
    p.c_grad.resize(3 * n, 2);
    p.c_grad.col(0) = flat(cv.grad_area);
    p.c_grad.col(1) = flat(cv.grad_volume);
    return true;
  };
  pb.hessian = [=](const Eigen::VectorXd& xf,
                   const Eigen::VectorXd& l) -> const Eigen::SparseMatrix<double>& {
    flat(s->x) = xf;
    BlockHessian& h = storage();
    h.set_zero();
    add_lagrangian_hessian(*m, s->x, l(0), l(1), h);
    if (extra.hessian) extra.hessian(s->x, h);
    return h.matrix();
  };
  pb.feasible = [m](const Eigen::VectorXd& from, const Eigen::VectorXd& to) {
    return !any_face_flipped(from, to, m->topo);
  };
  pb.constraint_scale = Eigen::Vector2d(a0, v0);
  return pb;
}

SectorStability NewtonSolver::check_sectors(const NewtonProblem& full, const Eigen::VectorXd& xf,
                                            const Eigen::VectorXd& l, const NewtonPoint* at_xf) {
  if (!reduction_) return {};
  if (!stability_) {
    // The stability verdict (is each sector's Hessian definite?) is taken in double, whatever
    // the Newton steps' precision: near a buckling force it must not move with float rounding.
    SparseCholeskyOptions check = shifted_newton_options(options_).cholesky;
    check.solve_precision = SolvePrecision::double_precision;
    stability_ = std::make_unique<SymmetryStabilityCheck>(reduced_group_symmetry_, check);
    for (int k = 0; k < stability_->sectors(); ++k)
      reduced_hessian_->add_sector(stability_->sector_reduction(k));
  }
  // Every sector from one pass over the representative elements' matrices.
  const Positions xs = Eigen::Map<const Positions>(xf.data(), 3, xf.size() / 3);
  reduced_hessian_->assemble_sectors(xs, l(0), l(1));
  // The force tolerance's residual fakes a negative curvature along the free rigid turns
  // (rigid_turn_residual_curvature): allowed for twice over.
  double allowance = 0.0;
  NewtonPoint evaluated;
  const NewtonPoint* p = at_xf;
  if (!p && full.evaluate(xf, evaluated)) p = &evaluated;
  if (p) {
    const Eigen::VectorXd r = p->grad + p->c_grad * l;
    allowance = 2.0 * rigid_turn_residual_curvature(
                          xs, Eigen::Map<const Positions>(r.data(), 3, r.size() / 3));
  }
  return stability_->check_sectors(
      [&](int k) -> const Eigen::SparseMatrix<double>& { return reduced_hessian_->sector(k); },
      kSectorShift, allowance);
}

SectorStability NewtonSolver::check_symmetric_state(double force_pN, const Positions& x,
                                                    const ConstraintMultipliers& lambda) {
  if (options_.symmetry == Symmetry::mirror) update_reduction();
  if (!reduction_) return {};
  const Eigen::VectorXd xf = flat(x);
  if ((expand(*reduction_, symmetric_part(*reduction_, xf)) - xf).cwiseAbs().maxCoeff() >
      kSymmetricStartUm)
    return {};  // not a symmetric state: a full solve's minimum, nothing to check
  const NewtonProblem full = full_problem(force_pN);
  return check_sectors(full, xf, Eigen::Vector2d(lambda.area_pN_per_um, lambda.volume_pN_per_um2));
}

NewtonSolver::Prepared NewtonSolver::prepare(double force_pN, const Positions& x) {
  if (options_.symmetry == Symmetry::mirror) update_reduction();
  Prepared p{full_problem(force_pN), {}, {}, false, &newton_};
  // A start off the symmetric states (a buckled equilibrium) is solved in full.
  p.reduced = static_cast<bool>(reduction_);
  if (p.reduced) {
    p.xf = symmetric_part(*reduction_, flat(x));
    p.reduced = (expand(*reduction_, p.xf) - flat(x)).cwiseAbs().maxCoeff() <= kSymmetricStartUm;
  }
  if (!p.reduced) p.xf = flat(x);
  if (!p.reduced && reduction_ && !full_newton_)
    full_newton_ = std::make_unique<ShiftedNewton>(shifted_newton_options(options_));
  if (!p.reduced && reduction_) p.method = full_newton_.get();
  ReducedHessian assemble_reduced;
  if (p.reduced)
    assemble_reduced = [this](const Eigen::VectorXd& xf_full,
                              const Eigen::VectorXd& l) -> const Eigen::SparseMatrix<double>& {
      const Positions xs = Eigen::Map<const Positions>(xf_full.data(), 3, xf_full.size() / 3);
      return reduced_hessian_->assemble(xs, l(0), l(1));
    };
  SymmetricEvaluate evaluate_symmetric;
  if (p.reduced) {
    // The symmetric states' energy from one element per orbit (the full problem's evaluate
    // still gives the reported full residual at the end).
    struct Scratch {
      Positions x, g;
      ConstraintValues c;
    };
    const auto n = static_cast<Eigen::Index>(model_->rest.cols());
    auto s = std::make_shared<Scratch>(Scratch{Positions(3, n), Positions(3, n), {}});
    evaluate_symmetric = [e = symmetric_energy_, s, force_pN, a0 = model_->area0_um2,
                          v0 = model_->volume0_um3](const Eigen::VectorXd& xf, NewtonPoint& pt) {
      flat(s->x) = xf;
      pt.value = e->evaluate(s->x, force_pN, s->g, s->c);
      if (!std::isfinite(pt.value)) return false;
      pt.grad = flat(s->g);
      pt.c = Eigen::Vector2d(s->c.area_um2 - a0, s->c.volume_um3 - v0);
      pt.c_grad.resize(xf.size(), 2);
      pt.c_grad.col(0) = flat(s->c.grad_area);
      pt.c_grad.col(1) = flat(s->c.grad_volume);
      return true;
    };
  }
  p.pb = p.reduced ? reduce_newton_problem(p.full, reduction_, reduced_cache_, assemble_reduced,
                                           evaluate_symmetric)
                   : p.full;
  return p;
}

bool NewtonSolver::factorise_at(double force_pN, const Positions& x,
                                const ConstraintMultipliers& lambda, int* factorisations) {
  Prepared p = prepare(force_pN, x);
  if (p.method != &newton_) return false;
  return newton_.factorise_at(
      p.pb, p.xf, Eigen::Vector2d(lambda.area_pN_per_um, lambda.volume_pN_per_um2), factorisations);
}

NewtonResult NewtonSolver::solve(double force_pN, Positions& x, ConstraintMultipliers& lambda,
                                 const ProgressSink& progress, const NewtonLimits& limits) {
  const double a0 = model_->area0_um2, v0 = model_->volume0_um3;
  Prepared prep = prepare(force_pN, x);
  const NewtonProblem& full = prep.full;
  const NewtonProblem& pb = prep.pb;
  const bool reduced = prep.reduced;
  Eigen::VectorXd& xf = prep.xf;
  ShiftedNewton& method = *prep.method;
  auto on_iteration = [&](const NewtonIterate& it) {
    if (!progress) return;
    std::ostringstream m;
    m << "  newton " << it.iteration << ": E = " << it.value << " pN um, residual = " << it.residual
      << " pN, area drift " << it.relative_c(0) << ", volume drift " << it.relative_c(1);
    report(progress, m.str());
  };
  NewtonLimitsCore lim;
  lim.max_iterations = limits.max_iterations;
  lim.deadline = limits.deadline;
  Eigen::VectorXd l = Eigen::Vector2d(lambda.area_pN_per_um, lambda.volume_pN_per_um2);
  ShiftedNewtonResult r = method.solve(pb, xf, l, on_iteration, lim);
  NewtonResult res;
  res.symmetry_order = reduced ? symmetry_order() : 1;
  res.status = r.status;
  res.iterations = r.iterations;
  res.factorisations = r.factorisations;
  res.chord_steps = r.chord_steps;
  res.krylov_iterations = r.krylov_iterations;
  res.krylov_fallbacks = r.krylov_fallbacks;
  res.residual_pN = r.residual;
  res.largest_shift = r.largest_shift;
  if (r.status == NewtonStatus::infeasible_start) return res;
  if (reduced) {
    // The full residual at the symmetric state (equal to the reduced one's per-vertex force up
    // to the rest mesh's asymmetry), reported instead of the reduced one. On a mesh symmetric
    // to rounding (kSymmetricMeshUm) the two are the same up to rounding, and the full
    // evaluation (8 times a reduced one on the 8-mirror mesh: a fifth of a warm re-solve's
    // time) is made only where the sector check needs it.
    xf = expand(*reduction_, xf);
    const bool checking = r.status == NewtonStatus::converged && options_.symmetry_check;
    NewtonPoint p;
    const bool evaluated =
        (checking || rest_asymmetry_um_ > kSymmetricMeshUm) && full.evaluate(xf, p);
    if (evaluated) {
      r.point = p;
      res.residual_pN = largest_block_norm(p.grad + p.c_grad * l, 3);
    }
    if (checking) {
      const SectorStability st = check_sectors(full, xf, l, evaluated ? &p : nullptr);
      res.stability_factorisations = st.factorisations;
      if (!st.stable) {
        // A saddle: pushed off along the unstable sector and solved in full.
        res.symmetry_broken = true;
        if (progress)
          report(progress, "  symmetric state unstable (sector " +
                               std::to_string(st.unstable_character) +
                               "): solving without the symmetry");
        Eigen::VectorXd push = stability_->sector_direction(st.unstable_character, 1);
        push /= push.cwiseAbs().maxCoeff();
        if (!full_newton_)
          full_newton_ = std::make_unique<ShiftedNewton>(shifted_newton_options(options_));
        const Eigen::VectorXd saddle = xf, saddle_lambda = l;
        int iterations = r.iterations, factorisations = r.factorisations;
        // Newton seeks critical points, not minima: just past the bifurcation, where the
        // saddle's negative curvature is weak, the full solve from a small push can creep
        // back or stall near the saddle (measured: a soft cell, p = 30 nm, Lmax = 500 nm, at
        // 108.8 pN, 1e-5 um in D_T from it at the iteration limit after a 1e-3 um push, where
        // the buckled state is 0.025 um away; from a 1e-2 um push it converged there). Then the
        // push grows by kSymmetryPushGrowth, kSymmetryPushAttempts pushes in all. The answer is
        // the first attempt that converged off the saddle, else the first attempt's (the one
        // answer before retries existed).
        double push_um = kSymmetryPushUm;
        for (int attempt = 1; attempt <= kSymmetryPushAttempts;
             ++attempt, push_um *= kSymmetryPushGrowth) {
          Eigen::VectorXd xa = saddle + push_um * push, la = saddle_lambda;
          ShiftedNewtonResult ra = full_newton_->solve(full, xa, la, on_iteration, lim);
          iterations += ra.iterations;
          factorisations += ra.factorisations;
          res.chord_steps += ra.chord_steps;
          res.krylov_iterations += ra.krylov_iterations;
          res.krylov_fallbacks += ra.krylov_fallbacks;
          res.largest_shift = std::max(res.largest_shift, ra.largest_shift);
          const double asymmetry =
              (expand(*reduction_, symmetric_part(*reduction_, xa)) - xa).cwiseAbs().maxCoeff();
          const bool left = ra.status == NewtonStatus::converged && asymmetry > kSymmetricStartUm;
          const NewtonStatus status = ra.status;
          if (attempt == 1 || left) {
            r = std::move(ra);
            xf = std::move(xa);
            l = std::move(la);
          }
          if (left || status == NewtonStatus::infeasible_start ||
              status == NewtonStatus::time_budget || attempt == kSymmetryPushAttempts)
            break;
          if (progress) {
            std::ostringstream m;
            m << "  ended " << asymmetry << " um from the symmetric saddle (" << to_string(status)
              << "): pushing " << kSymmetryPushGrowth << " times farther";
            report(progress, m.str());
          }
        }
        r.iterations = iterations;
        r.factorisations = factorisations;
        res.symmetry_order = 1;
        res.status = r.status;
        res.iterations = r.iterations;
        res.factorisations = r.factorisations;
        res.residual_pN = r.residual;
        if (r.status == NewtonStatus::infeasible_start) return res;
      }
    }
  }
  flat(x) = xf;
  // Broken: the answer is not symmetric (a saddle left, or a buckled start followed).
  if (reduction_)
    res.symmetry_broken =
        (expand(*reduction_, symmetric_part(*reduction_, xf)) - xf).cwiseAbs().maxCoeff() >
        kSymmetricStartUm;
  lambda = {l(0), l(1)};
  res.area_drift = r.point.c(0) / a0;
  res.volume_drift = r.point.c(1) / v0;
  res.energy_pNum = r.point.value;
  return res;
}

}  // namespace rbc
