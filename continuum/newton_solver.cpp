#include "continuum/newton_solver.hpp"

#include "core/blas_threads.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "core/lbfgs.hpp"
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
  require_integer_in_range("Newton supernodal threshold (unknowns)", supernodal_min_unknowns, 0,
                           std::numeric_limits<int>::max());
}

std::string to_string(NewtonStatus s) {
  switch (s) {
    case NewtonStatus::converged:
      return "converged";
    case NewtonStatus::max_iterations:
      return "iteration limit reached";
    case NewtonStatus::line_search_failed:
      return "line search failed";
    case NewtonStatus::infeasible_start:
      return "infeasible start";
    case NewtonStatus::time_budget:
      return "time budget exhausted";
  }
  return "unknown";
}

double largest_vertex_norm(const Positions& v) {
  return v.cols() ? v.colwise().norm().maxCoeff() : 0.0;
}

namespace {

/// State of one iterate: energy, gradient, constraints.
struct Iterate {
  double energy = 0;
  Positions grad;
  ConstraintValues cons;
};

bool evaluate(const ContinuumModel& m, double force, const Positions& x, Iterate& it) {
  it.energy = continuum_energy(m, x, force, &it.grad);
  if (!std::isfinite(it.energy)) return false;
  it.cons = evaluate_constraints(x, m.topo);
  return true;
}

/// Unnormalised face normals (b - a) x (c - a), 3 x F.
Eigen::Matrix3Xd face_normals(const Positions& x, const Topology& topo) {
  Eigen::Matrix3Xd n(3, topo.num_faces());
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto t = topo.faces.col(f);
    n.col(f) = (x.col(t(1)) - x.col(t(0))).cross(x.col(t(2)) - x.col(t(0)));
  }
  return n;
}

bool any_face_flipped(const Positions& x, const Topology& topo, const Eigen::Matrix3Xd& before) {
  const Eigen::Matrix3Xd after = face_normals(x, topo);
  return ((after.cwiseProduct(before)).colwise().sum().array() <= 0.0).any();
}

}  // namespace

NewtonSolver::NewtonSolver(const ContinuumModel& model, const NewtonOptions& options)
    : model_(model), options_(options), hessian_(model.topo) {
  options_.validate();
  ldlt_.setMode(3 * model.topo.num_vertices >= options_.supernodal_min_unknowns
                    ? Eigen::CholmodSupernodalLLt
                    : Eigen::CholmodSimplicialLLt);
  switch (options_.ordering) {
    case FillOrdering::automatic:
      break;
    case FillOrdering::amd:
    case FillOrdering::metis:
    case FillOrdering::nested_dissection:
      ldlt_.cholmod().nmethods = 1;
      ldlt_.cholmod().method[0].ordering = options_.ordering == FillOrdering::amd ? CHOLMOD_AMD
                                           : options_.ordering == FillOrdering::metis
                                               ? CHOLMOD_METIS
                                               : CHOLMOD_NESDIS;
      break;
  }
  ldlt_.cholmod().print = 0;  // library code does not print: a failed (indefinite) trial is
                              // expected and handled by the shift loop
  ldlt_.analyzePattern(hessian_.matrix());
}

NewtonResult NewtonSolver::solve(double force_pN, Positions& x, ConstraintMultipliers& lambda,
                                 const ProgressSink& progress, const NewtonLimits& limits) {
  const int max_iterations = limits.max_iterations >= 0
                                 ? std::min(limits.max_iterations, options_.max_iterations)
                                 : options_.max_iterations;
  NewtonResult res;
  const double a0 = model_.area0_um2, v0 = model_.volume0_um3;
  Iterate cur, trial;
  if (!evaluate(model_, force_pN, x, cur)) {
    res.status = NewtonStatus::infeasible_start;
    return res;
  }
  const int n = static_cast<int>(x.cols());
  Eigen::SparseMatrix<double> k = hessian_.matrix();
  std::vector<int> diag(3 * n);
  for (int c = 0; c < 3 * n; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(k, c); it; ++it)
      if (it.row() == c) diag[c] = static_cast<int>(&it.valueRef() - k.valuePtr());
  double shift_hint = 0.0, last_resid = 0.0;
  bool have_factor = false, last_full_step = false;
  int reuse_count = 0;
  Positions r;
  auto finish = [&](NewtonStatus s) {
    res.status = s;
    res.residual_pN = largest_vertex_norm(r);
    res.area_drift = (cur.cons.area_um2 - a0) / a0;
    res.volume_drift = (cur.cons.volume_um3 - v0) / v0;
    res.energy_pNum = cur.energy;
    return res;
  };
  for (int iter = 0;; ++iter) {
    throw_if_cancelled(options_.cancel);
    r = cur.grad + lambda.area_pN_per_um * cur.cons.grad_area +
        lambda.volume_pN_per_um2 * cur.cons.grad_volume;
    const double resid = largest_vertex_norm(r);
    const Eigen::Vector2d c(cur.cons.area_um2 - a0, cur.cons.volume_um3 - v0);
    const Eigen::Vector2d scale(a0, v0);
    const Eigen::Vector2d chat = c.cwiseQuotient(scale);
    res.iterations = iter;
    {
      std::ostringstream m;
      m << "  newton " << iter << ": E = " << cur.energy << " pN um, residual = " << resid
        << " pN, area drift " << chat(0) << ", volume drift " << chat(1);
      report(progress, m.str());
    }
    if (resid < options_.force_tolerance_pN &&
        chat.cwiseAbs().maxCoeff() < options_.constraint_tolerance)
      return finish(NewtonStatus::converged);
    if (iter >= max_iterations) return finish(NewtonStatus::max_iterations);
    if (std::chrono::steady_clock::now() > limits.deadline)
      return finish(NewtonStatus::time_budget);

    // Assemble K = d2E + lambda_A d2A + lambda_V d2V and factorise with a shift, unless the
    // previous factorisation is still doing well (chord step: the last full step cut the
    // residual at least fourfold), which saves the dominant cost on nearby iterates.
    const bool reuse = have_factor && last_full_step &&
                       resid < options_.reuse_contraction * last_resid &&
                       reuse_count < options_.max_factor_reuse;
    if (reuse) {
      ++reuse_count;
    } else {
      reuse_count = 0;
      hessian_.set_zero();
      add_continuum_hessian(model_, x, hessian_);
      add_constraint_hessian(x, model_.topo, lambda.area_pN_per_um, lambda.volume_pN_per_um2,
                             hessian_);
      const Eigen::SparseMatrix<double>& h = hessian_.matrix();
      double mean_diag = 0;
      for (int d : diag) mean_diag += std::abs(h.valuePtr()[d]);
      mean_diag = std::max(mean_diag / (3.0 * n), 1e-300);
      double sigma = std::max(1e-8, shift_hint);
      bool factorised = false;
      for (int attempt = 0; attempt < 30; ++attempt) {
        std::copy(h.valuePtr(), h.valuePtr() + h.nonZeros(), k.valuePtr());
        for (int d : diag) k.valuePtr()[d] += sigma * mean_diag;
        {
          const ScopedBlasThreads blas(options_.blas_threads);
          ldlt_.factorize(k);
        }
        ++res.factorisations;
        if (ldlt_.info() == Eigen::Success) {  // CHOLMOD fails unless K is positive definite
          factorised = true;
          break;
        }
        sigma = std::max(10.0 * sigma, 1e-4);
      }
      if (!factorised) return finish(NewtonStatus::line_search_failed);
      have_factor = true;
      res.largest_shift = std::max(res.largest_shift, sigma);
      shift_hint = sigma > 1e-8 ? 0.01 * sigma : 0.0;
    }
    last_resid = resid;

    // Bordered solve with the 2 x 2 Schur complement.
    Eigen::MatrixXd cm(3 * n, 2);
    cm.col(0) = flat(cur.cons.grad_area);
    cm.col(1) = flat(cur.cons.grad_volume);
    Eigen::VectorXd y0;
    Eigen::MatrixXd ym;
    {
      const ScopedBlasThreads blas(options_.blas_threads);
      y0 = ldlt_.solve(flat(r));
      ym = ldlt_.solve(cm);
    }
    const Eigen::Matrix2d s = cm.transpose() * ym;
    const Eigen::Vector2d dl = s.fullPivLu().solve(c - cm.transpose() * y0);
    Eigen::VectorXd dx = -y0 - ym * dl;
    const ConstraintMultipliers lnew{lambda.area_pN_per_um + dl(0),
                                     lambda.volume_pN_per_um2 + dl(1)};
    const double largest = largest_vertex_norm(Eigen::Map<const Eigen::Matrix3Xd>(dx.data(), 3, n));
    if (largest > options_.max_step_um) dx *= options_.max_step_um / largest;
    const Positions dxp = Eigen::Map<const Eigen::Matrix3Xd>(dx.data(), 3, n);

    // Merit phi = E + lnew'c + rho/2 |c/G|^2 and its slope along dx.
    const double rho = options_.penalty_pNum;
    auto merit = [&](const Iterate& it) {
      const Eigen::Vector2d ci(it.cons.area_um2 - a0, it.cons.volume_um3 - v0);
      return it.energy + lnew.area_pN_per_um * ci(0) + lnew.volume_pN_per_um2 * ci(1) +
             0.5 * rho * ci.cwiseQuotient(scale).squaredNorm();
    };
    const Eigen::VectorXd gm = flat(cur.grad) +
                               cm * Eigen::Vector2d(lnew.area_pN_per_um, lnew.volume_pN_per_um2) +
                               cm * Eigen::Vector2d(rho * chat(0) / a0, rho * chat(1) / v0);
    const double slope = gm.dot(dx);
    const double phi0 = merit(cur);
    const Eigen::Matrix3Xd normals = face_normals(x, model_.topo);
    double t = 1.0;
    bool accepted = false;
    Positions xt;
    for (int ls = 0; ls < options_.max_line_search; ++ls, t *= 0.5) {
      xt = x + t * dxp;
      if (any_face_flipped(xt, model_.topo, normals) || !evaluate(model_, force_pN, xt, trial))
        continue;  // infeasible: halve
      const double phi = merit(trial);
      const bool armijo = slope < 0 && phi <= phi0 + 1e-4 * t * slope;
      // Near convergence phi changes at the level of round-off: accept a step that does
      // not raise phi beyond that and reduces the net force.
      bool roundoff_ok = false;
      if (!armijo && phi <= phi0 + 1e-12 * std::abs(phi0)) {
        const Positions rt = trial.grad + lnew.area_pN_per_um * trial.cons.grad_area +
                             lnew.volume_pN_per_um2 * trial.cons.grad_volume;
        roundoff_ok = largest_vertex_norm(rt) < resid;
      }
      if (armijo || roundoff_ok) {
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (reuse) {  // a stale factorisation may give a poor direction: retry with a fresh one
        have_factor = false;
        continue;
      }
      return finish(NewtonStatus::line_search_failed);
    }
    last_full_step = t == 1.0;
    x = xt;
    std::swap(cur, trial);
    lambda = lnew;
  }
}

}  // namespace rbc
