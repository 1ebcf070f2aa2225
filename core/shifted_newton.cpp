// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/shifted_newton.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "core/validation.hpp"

namespace rbc {

void ShiftedNewtonOptions::validate() const {
  require_finite_in_range("Newton force tolerance", "", force_tolerance, 0.0, kUnbounded);
  require_finite_in_range("Newton relative constraint tolerance", "", constraint_tolerance, 0.0,
                          1.0, Ends::open_open);
  require_integer_in_range("Newton max iterations", max_iterations, 0, 100000000);
  require_integer_in_range("Newton block size", block_size, 1, 64);
  if (!(max_step > 0))
    throw std::invalid_argument("Newton largest step must be > 0 (infinity = no cap), got " +
                                format_number(max_step));
  require_integer_in_range("line-search halvings", max_line_search, 1, 1000);
  require_finite_in_range("Armijo constant", "", armijo, 0.0, 0.5, Ends::open_open);
  require_finite_in_range("Armijo round-off slack", "", armijo_slack_rel, 0.0, 1e-6,
                          Ends::closed_closed);
  require_finite_in_range("round-off merit tolerance", "", roundoff_merit_rel, 0.0, 1e-6,
                          Ends::closed_closed);
  require_finite_in_range("merit penalty", "", penalty, 0.0, kUnbounded, Ends::closed_open);
  require_finite_in_range("initial Newton shift", "", initial_shift, 0.0, 1.0, Ends::closed_closed);
  require_finite_in_range("retry Newton shift", "", retry_shift, 0.0, 1.0, Ends::open_closed);
  require_finite_in_range("Newton shift growth", "", shift_growth, 1.0, 1e6, Ends::open_closed);
  require_finite_in_range("Newton shift memory", "", shift_memory, 0.0, 1.0, Ends::closed_closed);
  require_integer_in_range("Newton shift attempts", max_shift_attempts, 1, 1000);
  require_integer_in_range("factorisation reuse", max_factor_reuse, 0, 1000);
  require_finite_in_range("reuse contraction", "", reuse_contraction, 0.0, 1.0, Ends::open_open);
  require_integer_in_range("Krylov correction iterations (0 = off)", krylov_iterations, 0, 100000);
  require_finite_in_range("Krylov correction tolerance", "", krylov_tolerance, 0.0, 1.0,
                          Ends::open_open);
  require_finite_in_range("Krylov kept shift", "", krylov_kept_shift, 0.0, 1.0,
                          Ends::closed_closed);
  require_integer_in_range("Krylov refactorisation iterations", krylov_refactor_iterations, 0,
                           100000);
  require_integer_in_range("Krylov lagged-correction iterations (0 = krylov_iterations)",
                           krylov_lagged_iterations, 0, 100000);
  require_integer_in_range("Newton stall iterations (0 = off)", stall_iterations, 0, 1000000);
  require_finite_in_range("Newton round-off floor factor", "", floor_factor, 0.0, kUnbounded,
                          Ends::closed_open);
  cholesky.validate();
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
    case NewtonStatus::factorisation_failed:
      return "factorisation failed";
  }
  return "unknown";
}

MinimiserStatus minimiser_status(NewtonStatus s) {
  switch (s) {
    case NewtonStatus::converged:
      return MinimiserStatus::converged;
    case NewtonStatus::max_iterations:
    case NewtonStatus::time_budget:
      return MinimiserStatus::max_iterations;
    case NewtonStatus::line_search_failed:
      return MinimiserStatus::line_search_failed;
    case NewtonStatus::infeasible_start:
      return MinimiserStatus::infeasible_start;
    case NewtonStatus::factorisation_failed:
      return MinimiserStatus::factorisation_failed;
  }
  return MinimiserStatus::line_search_failed;
}

NewtonStatus newton_status(MinimiserStatus s) {
  switch (s) {
    case MinimiserStatus::converged:
      return NewtonStatus::converged;
    case MinimiserStatus::max_iterations:
      return NewtonStatus::max_iterations;
    case MinimiserStatus::line_search_failed:
      return NewtonStatus::line_search_failed;
    case MinimiserStatus::infeasible_start:
      return NewtonStatus::infeasible_start;
    case MinimiserStatus::factorisation_failed:
      return NewtonStatus::factorisation_failed;
  }
  return NewtonStatus::line_search_failed;
}

double largest_block_norm(const Eigen::VectorXd& v, int block_size) {
  if (v.size() == 0) return 0.0;
  const Eigen::Map<const Eigen::MatrixXd> m(v.data(), block_size, v.size() / block_size);
  return m.colwise().norm().maxCoeff();
}

ShiftedNewton::ShiftedNewton(const ShiftedNewtonOptions& options)
    : options_(options), cholesky_((options.validate(), options.cholesky)) {}

void ShiftedNewton::prepare_pattern(const Eigen::SparseMatrix<double>& h) {
  if (h.rows() == analysed_rows_ && h.nonZeros() == analysed_nonzeros_) return;
  if (!h.isCompressed() || h.rows() != h.cols())
    throw std::logic_error("shifted Newton: the Hessian must be square and compressed");
  k_ = h;
  const Eigen::Index n = h.rows();
  diag_.assign(n, -1);
  for (Eigen::Index c = 0; c < n; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(k_, c); it; ++it)
      if (it.row() == c) diag_[c] = static_cast<int>(&it.valueRef() - k_.valuePtr());
  if (std::find(diag_.begin(), diag_.end(), -1) != diag_.end())
    throw std::logic_error("shifted Newton: the Hessian pattern lacks a diagonal entry");
  cholesky_.analyze(k_);
  analysed_rows_ = n;
  analysed_nonzeros_ = h.nonZeros();
  have_factor_ = false;
}

int ShiftedNewton::krylov_correct(const Eigen::SparseMatrix<double>& h, double diag_shift,
                                  int max_its, const Eigen::MatrixXd& c_grad,
                                  const Eigen::MatrixXd& ym,
                                  const Eigen::FullPivLU<Eigen::MatrixXd>& sc,
                                  const Eigen::VectorXd& r, const Eigen::VectorXd& y0,
                                  Eigen::VectorXd& dx, Eigen::VectorXd& dl) const {
  const Eigen::Index m = c_grad.cols();
  // Projected preconditioned residual: [P C; C' 0] [z; w] = [g; 0], P the factorised K.
  Eigen::VectorXd w(m);
  auto project = [&](const Eigen::VectorXd& g) {
    Eigen::VectorXd z = cholesky_.solve(g);
    if (m > 0) {
      w = sc.solve(Eigen::VectorXd(c_grad.transpose() * z));
      z -= ym * w;
    }
    return z;
  };
  const auto hs = h.selfadjointView<Eigen::Lower>();
  const double reference = r.dot(y0);  // r' P^-1 r > 0
  const double tol2 = options_.krylov_tolerance * options_.krylov_tolerance * reference;
  Eigen::VectorXd g = hs * dx - diag_shift * dx + r;  // gradient of the quadratic model at dx
  Eigen::VectorXd z = project(g);
  double rz = g.dot(z);
  Eigen::VectorXd p = -z, hp;
  for (int k = 0;; ++k) {
    if (!(rz > tol2)) {  // converged (rz >= 0 in exact arithmetic with a K-orthogonal projection)
      // g = H dx + r = C w on convergence: H dx + C dl = -r with dl = -w.
      dl = m > 0 ? Eigen::VectorXd(-w) : Eigen::VectorXd();
      return k;
    }
    if (!std::isfinite(rz)) return -(k + 1);
    // Truncated (Steihaug): at the iteration limit, or on negative curvature on the tangent
    // space after the first iteration, the current iterate (a descent direction of the
    // quadratic model there) is the step.
    if (k >= max_its) {
      dl = m > 0 ? Eigen::VectorXd(-w) : Eigen::VectorXd();
      return k;
    }
    hp = hs * p - diag_shift * p;
    const double php = p.dot(hp);
    if (!(php > 0)) {
      if (k == 0) return -1;
      dl = m > 0 ? Eigen::VectorXd(-w) : Eigen::VectorXd();
      return k;
    }
    const double alpha = rz / php;
    dx += alpha * p;
    g += alpha * hp;
    if (k + 1 >= max_its && max_its < options_.krylov_iterations) {
      // Truncated before the convergence test: its projection (a solve) would serve only the
      // test. The multipliers are those of the last projection.
      dl = m > 0 ? Eigen::VectorXd(-w) : Eigen::VectorXd();
      return k + 1;
    }
    z = project(g);
    const double rz_new = g.dot(z);
    p = -z + (rz_new / rz) * p;
    rz = rz_new;
  }
}

ShiftedNewton ShiftedNewton::clone() const {
  ShiftedNewton c(options_);
  c.cholesky_ = cholesky_.clone();
  c.k_ = k_;
  c.diag_ = diag_;
  c.analysed_rows_ = analysed_rows_;
  c.analysed_nonzeros_ = analysed_nonzeros_;
  c.have_factor_ = have_factor_;
  c.shift_hint_ = shift_hint_;
  c.last_krylov_iterations_ = last_krylov_iterations_;
  c.factor_shift_ = factor_shift_;
  c.factor_scale_ = factor_scale_;
  return c;
}

double ShiftedNewton::factorise_shifted(const NewtonProblem& pb,
                                        const Eigen::SparseMatrix<double>& h, double sigma,
                                        int& factorisations) {
  const ShiftedNewtonOptions& o = options_;
  prepare_pattern(h);
  double s = 0;
  if (o.shift_scale == ShiftScale::mean_abs_diagonal) {
    for (int d : diag_) s += std::abs(h.valuePtr()[d]);
    s = std::max(s / static_cast<double>(h.rows()), 1e-300);
  } else {
    for (int d : diag_) s = std::max(s, std::abs(h.valuePtr()[d]));
  }
  have_factor_ = false;
  for (int attempt = 0; attempt < o.max_shift_attempts; ++attempt) {
    std::copy(h.valuePtr(), h.valuePtr() + h.nonZeros(), k_.valuePtr());
    if (sigma > 0)
      for (int d : diag_) k_.valuePtr()[d] += sigma * s;
    if (pb.add_unshifted) pb.add_unshifted(k_);
    ++factorisations;
    if (cholesky_.factorize(k_)) {  // fails unless K is positive definite
      have_factor_ = true;
      factor_shift_ = sigma > 0 ? sigma * s : 0.0;
      factor_scale_ = s;
      return sigma;
    }
    sigma = std::max(o.shift_growth * sigma, o.retry_shift);
  }
  return -1.0;
}

void ShiftedNewton::swap(ShiftedNewton& other) noexcept {
  using std::swap;
  swap(options_, other.options_);
  swap(cholesky_, other.cholesky_);
  k_.swap(other.k_);
  diag_.swap(other.diag_);
  swap(analysed_rows_, other.analysed_rows_);
  swap(analysed_nonzeros_, other.analysed_nonzeros_);
  swap(have_factor_, other.have_factor_);
  swap(shift_hint_, other.shift_hint_);
  swap(last_krylov_iterations_, other.last_krylov_iterations_);
  swap(factor_shift_, other.factor_shift_);
  swap(factor_scale_, other.factor_scale_);
}

bool ShiftedNewton::factorise_at(const NewtonProblem& pb, const Eigen::VectorXd& x,
                                 const Eigen::VectorXd& lambda, int* factorisations) {
  const Eigen::SparseMatrix<double>& h = pb.hessian(x, lambda);
  if (h.rows() != x.size()) throw std::logic_error("shifted Newton: Hessian size mismatch");
  int made = 0;
  last_krylov_iterations_ = 0;
  const bool ok = factorise_shifted(pb, h, options_.initial_shift, made) >= 0;
  if (factorisations) *factorisations += made;
  return ok;
}

ShiftedNewtonResult ShiftedNewton::solve(const NewtonProblem& pb, Eigen::VectorXd& x,
                                         Eigen::VectorXd& lambda,
                                         const std::function<void(const NewtonIterate&)>& on_it,
                                         const NewtonLimitsCore& limits) {
  const ShiftedNewtonOptions& o = options_;
  const int max_iterations = limits.max_iterations >= 0
                                 ? std::min(limits.max_iterations, o.max_iterations)
                                 : o.max_iterations;
  const double tolerance = limits.force_tolerance >= 0 ? limits.force_tolerance : o.force_tolerance;
  ShiftedNewtonResult res;
  NewtonPoint& cur = res.point;
  NewtonPoint trial;
  auto evaluate = [&](const Eigen::VectorXd& at, NewtonPoint& p) {
    return pb.evaluate(at, p) && std::isfinite(p.value);
  };
  if (!evaluate(x, cur)) {
    res.status = NewtonStatus::infeasible_start;
    return res;
  }
  const Eigen::Index n = x.size();
  const Eigen::Index m = cur.c.size();
  if (lambda.size() != m) lambda = Eigen::VectorXd::Zero(m);
  const Eigen::VectorXd& scale = pb.constraint_scale;
  if (m > 0 && scale.size() != m)
    throw std::logic_error("shifted Newton: one constraint scale per constraint needed");
  // A held factorisation of another problem size is no use (a caller that swaps methods
  // between problems of the same size must drop it itself: NewtonSolver::update_reduction).
  if (!o.reuse_across_calls || cholesky_.rows() != x.size()) have_factor_ = false;
  if (o.krylov_iterations > 0 && pb.add_unshifted)
    throw std::logic_error("shifted Newton: the Krylov correction needs the whole Hessian");
  last_krylov_iterations_ = 0;
  double shift_hint = 0.0, last_resid = 0.0;
  // A factorisation kept from the previous call counts as a full step's: the first
  // iteration may be a chord step on it.
  bool last_full_step = have_factor_, first = have_factor_;
  int reuse_count = 0;
  // krylov_exact_when_far: set once a step of this call was backtracked or a factorisation
  // needed its shift to grow.
  bool far_seen = false;
  Eigen::VectorXd r;
  // Best iterate for the round-off floor.
  double best = std::numeric_limits<double>::infinity();
  int stalled = 0;
  Eigen::VectorXd x_best;
  NewtonPoint p_best;
  auto residual_norm = [&](const Eigen::VectorXd& v) {
    return pb.residual_norm ? pb.residual_norm(v) : largest_block_norm(v, o.block_size);
  };
  auto residual_vector = [&](const NewtonPoint& p, const Eigen::VectorXd& l) {
    Eigen::VectorXd v = p.grad;
    for (Eigen::Index k = 0; k < m; ++k) v += l(k) * p.c_grad.col(k);
    return v;
  };
  Eigen::VectorXd l_best;
  // K^-1 C of the current factorisation (krylov_lagged_constraints), and the factorisation
  // count it was made at (another factorisation makes it stale).
  Eigen::MatrixXd ym_lag;
  int ym_lag_factorisations = -1;
  auto finish = [&](NewtonStatus s) {
    res.status = s;
    res.residual = residual_norm(r);
    // Not converged: return the best iterate seen (smallest residual), not a diverging last
    // one (a 5,120-element solve at 130 pN ended at 1e57 pN after passing 4 pN).
    if (s != NewtonStatus::converged && std::isfinite(best) && !(res.residual <= best)) {
      x = x_best;
      cur = p_best;
      lambda = l_best;
      r = residual_vector(cur, lambda);
      res.residual = residual_norm(r);
    }
    return res;
  };
  for (int iter = 0;; ++iter) {
    throw_if_cancelled(o.cancel);
    r = residual_vector(cur, lambda);
    const double resid = residual_norm(r);
    const Eigen::VectorXd chat =
        m > 0 ? Eigen::VectorXd(cur.c.cwiseQuotient(scale)) : Eigen::VectorXd();
    const double violation = m > 0 ? chat.cwiseAbs().maxCoeff() : 0.0;
    res.iterations = iter;
    if (on_it) on_it(NewtonIterate{iter, cur.value, resid, violation, chat});
    if (resid <= tolerance && violation < o.constraint_tolerance)
      return finish(NewtonStatus::converged);
    if (resid < best) {
      if (resid <= 0.5 * best) stalled = -1;
      best = resid;
      x_best = x;
      p_best = cur;
      l_best = lambda;
    }
    if (o.stall_iterations > 0) {
      if (++stalled >= o.stall_iterations && best <= o.floor_factor * tolerance &&
          violation < o.constraint_tolerance) {
        // At the floor: the best iterate seen (later steps only wander within round-off).
        x = x_best;
        cur = p_best;
        r = residual_vector(cur, lambda);
        res.at_roundoff_floor = true;
        return finish(NewtonStatus::converged);
      }
    }
    if (iter >= max_iterations) return finish(NewtonStatus::max_iterations);
    if (std::chrono::steady_clock::now() > limits.deadline)
      return finish(NewtonStatus::time_budget);

    // Factorise K = H + sigma s I afresh, unless the last factorisation is still doing well
    // (chord step: the last full step cut the residual by reuse_contraction), which saves the
    // dominant cost on nearby iterates.
    const bool krylov = o.krylov_iterations > 0;
    const bool lagged = krylov && o.krylov_lagged_hessian && !far_seen;
    const bool contracted = last_full_step && (first || resid < o.reuse_contraction * last_resid);
    const bool reuse =
        have_factor_ && reuse_count < o.max_factor_reuse &&
        (krylov && !lagged ? last_krylov_iterations_ >= 0 &&
                                 last_krylov_iterations_ <= o.krylov_refactor_iterations
                           : contracted && last_krylov_iterations_ >= 0);
    first = false;
    // The exact Hessian: for the factorisation, and with the Krylov correction at every
    // iteration (the chord steps' too) unless it uses the factorised one (lagged).
    const Eigen::SparseMatrix<double>* hk = nullptr;
    if ((krylov && !lagged) || !reuse) {
      hk = &pb.hessian(x, lambda);
      if (hk->rows() != n) throw std::logic_error("shifted Newton: Hessian size mismatch");
    }
    if (reuse) {
      ++reuse_count;
      ++res.chord_steps;
    } else {
      reuse_count = 0;
      const double start = std::max(o.initial_shift, shift_hint);
      const double sigma = factorise_shifted(pb, *hk, start, res.factorisations);
      if (sigma != start && o.krylov_exact_when_far) far_seen = true;
      if (!have_factor_) return finish(NewtonStatus::factorisation_failed);
      res.largest_shift = std::max(res.largest_shift, sigma);
      shift_hint = sigma > o.initial_shift ? o.shift_memory * sigma : 0.0;
    }
    last_resid = resid;

    // Bordered solve with the m x m Schur complement (r and C solved apart: one multi-column
    // solve of [r C] rounds differently enough to stall round-off-level tests).
    const Eigen::VectorXd y0 = cholesky_.solve(r);
    Eigen::VectorXd dx;
    Eigen::VectorXd lnew = lambda;
    // K^-1 C (n x m). Lagged constraint solves: a chord step keeps that of the first step on
    // this factorisation in this call (C' below is the current one, so the step still
    // satisfies the linearised constraints exactly; the Lagrangian row uses the lagged C).
    const Eigen::MatrixXd& ym = ym_lag;
    bool ym_reused = false;
    Eigen::FullPivLU<Eigen::MatrixXd> sc_lu;
    if (m > 0) {
      ym_reused = o.krylov_lagged_constraints && lagged && reuse && ym_lag.rows() == n &&
                  ym_lag.cols() == m && ym_lag_factorisations == res.factorisations;
      if (!ym_reused) {
        ym_lag = cholesky_.solve(cur.c_grad);
        ym_lag_factorisations = res.factorisations;
      }
      sc_lu.compute(Eigen::MatrixXd(cur.c_grad.transpose() * ym));
      const Eigen::VectorXd dl = sc_lu.solve(cur.c - cur.c_grad.transpose() * y0);
      dx = -y0 - ym * dl;
      lnew += dl;
    } else {
      dx = -y0;
    }
    // The shifted (or chord) step, kept as the fallback of the Krylov correction.
    Eigen::VectorXd dx_shifted, l_shifted;
    bool corrected = false;
    // Lagged correction of a factorisation made at no more than the kept shift: the step is
    // already exact for the Hessian the correction would use (it would stop after one
    // projection, a wasted solve).
    // (Only with a double factor: a float one is itself a model of K.)
    const bool exact_already =
        lagged && o.cholesky.solve_precision != SolvePrecision::single_precision_factorisation &&
        !(factor_shift_ - o.krylov_kept_shift * factor_scale_ > 0);
    if (krylov && exact_already) {
      last_krylov_iterations_ = 0;
    } else if (krylov) {
      dx_shifted = dx;
      l_shifted = lnew;
      Eigen::VectorXd dl_exact;
      // The correction keeps krylov_kept_shift of the shift (the rigid null modes stay
      // regularised as with the smallest shift alone).
      const double kept = o.krylov_kept_shift * factor_scale_;
      // With a reused K^-1 C the projection is oblique (C' of now, K^-1 C of before): a
      // preconditioner for one CG step, not for conjugate ones.
      const int lagged_its = ym_reused ? 1
                             : o.krylov_lagged_iterations > 0
                                 ? std::min(o.krylov_lagged_iterations, o.krylov_iterations)
                                 : o.krylov_iterations;
      const int its = lagged ? krylov_correct(k_, factor_shift_ - kept, lagged_its, cur.c_grad, ym,
                                              sc_lu, r, y0, dx, dl_exact)
                             : krylov_correct(*hk, -kept, o.krylov_iterations, cur.c_grad, ym,
                                              sc_lu, r, y0, dx, dl_exact);
      res.krylov_iterations += std::abs(its);
      last_krylov_iterations_ = its;
      if (its >= 0) {
        corrected = true;
        lnew = lambda + dl_exact;
      } else {
        dx = dx_shifted;
        ++res.krylov_fallbacks;
      }
    }
    // Capped step along dx with multipliers ln, backtracked on the merit
    //   phi = f + ln'c + rho/2 |c/G|^2;
    // true (xt, trial, t set) when a trial point is accepted.
    Eigen::VectorXd xt;
    double t = 1.0;
    auto line_search = [&](Eigen::VectorXd d, const Eigen::VectorXd& ln) {
      if (pb.project_step) pb.project_step(x, d);
      const double largest = pb.step_norm ? pb.step_norm(d) : largest_block_norm(d, o.block_size);
      if (largest > o.max_step) d *= o.max_step / largest;
      const double rho = o.penalty;
      auto merit = [&](const NewtonPoint& p) {
        double phi = p.value;
        for (Eigen::Index k = 0; k < m; ++k) phi += ln(k) * p.c(k);
        if (m > 0) phi += 0.5 * rho * p.c.cwiseQuotient(scale).squaredNorm();
        return phi;
      };
      Eigen::VectorXd gm = cur.grad;
      if (m > 0) {  // (grad f + C ln) + C rho c/G^2, in this order
        gm += cur.c_grad * ln;
        gm += cur.c_grad * Eigen::VectorXd(rho * chat.cwiseQuotient(scale));
      }
      const double slope = gm.dot(d);
      // The corrected step of an indefinite d2L need not descend: the caller falls back.
      if (corrected && !(slope < 0)) return false;
      const double phi0 = merit(cur);
      t = 1.0;
      for (int ls = 0; ls < o.max_line_search; ++ls, t *= 0.5) {
        xt = x + t * d;
        if ((pb.feasible && !pb.feasible(x, xt)) || !evaluate(xt, trial))
          continue;  // infeasible: halve
        const double phi = merit(trial);
        const bool armijo =
            slope < 0 && phi <= phi0 + o.armijo * t * slope + o.armijo_slack_rel * std::abs(phi0);
        // Near convergence phi changes at the level of round-off: accept a step that does
        // not raise phi beyond that and reduces the residual.
        bool roundoff_ok = false;
        if (!armijo && o.roundoff_merit_rel > 0 &&
            phi <= phi0 + o.roundoff_merit_rel * std::abs(phi0))
          roundoff_ok = residual_norm(residual_vector(trial, ln)) < resid;
        if (armijo || roundoff_ok) return true;
      }
      return false;
    };
    bool accepted = line_search(dx, lnew);
    if (!accepted && corrected) {  // the shifted step instead
      corrected = false;
      ++res.krylov_fallbacks;
      last_krylov_iterations_ = -1;
      lnew = l_shifted;
      accepted = line_search(dx_shifted, lnew);
    }
    if (!accepted) {
      if (reuse) {  // a stale factorisation may give a poor direction: retry with a fresh one
        have_factor_ = false;
        continue;
      }
      return finish(NewtonStatus::line_search_failed);
    }
    last_full_step = t == 1.0;
    if (!last_full_step && o.krylov_exact_when_far) far_seen = true;  // backtracked: far
    x = xt;
    std::swap(cur, trial);
    lambda = lnew;
  }
}

}  // namespace rbc
