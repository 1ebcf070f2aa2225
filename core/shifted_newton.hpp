// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The project's one shifted Newton method with backtracking line search, for
//   stationary points of L(x, lambda) = f(x) + lambda' c(x),   c(x) = 0 (m >= 0 equalities),
// used by the continuum equilibrium (continuum/newton_solver.hpp), the continuum backward-Euler
// step (continuum/dynamics.hpp) and the periodic cell problem (homogenise/periodic_network.hpp).
// Each iteration solves the bordered KKT system
//   [K  C] [dx     ]     [r]     r = grad f + C lambda,  C = dc/dx (n x m),
//   [C' 0] [dlambda] = - [c],    K = d2L + sigma s I,
// by one sparse Cholesky factorisation of K (core/sparse_cholesky.hpp) and the m x m Schur
// complement C' K^-1 C. The Levenberg shift sigma (relative to the diagonal scale s: mean or
// largest |K_ii|) starts at initial_shift (or a fraction of the last successful one) and
// grows until K is positive definite, so the direction is a descent direction of
//   phi = f + lambda_new' c + (rho/2) sum_k (c_k/G_k)^2   (rho = penalty, G = constraint scale),
// phi' = -dx'K dx - rho |c/G|^2. The step is capped so no block of dx (block_size entries, e.g.
// a vertex) is longer than max_step, then halved until phi satisfies Armijo's condition (or,
// near convergence, phi does not rise beyond round-off and the residual falls). A trial point
// outside the domain (f not finite, or the caller's feasibility check false) is halved too, so
// no NaN enters the iterate. Chord steps (modified Newton) reuse the last factorisation while
// each full step contracts the residual by reuse_contraction, optionally across calls (time
// steps, continuation): then the first iteration of a call is a chord step on the previous
// call's factorisation.
#include <Eigen/Core>
#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <chrono>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/lbfgs.hpp"  // MinimiserStatus
#include "core/progress.hpp"
#include "core/sparse_cholesky.hpp"

namespace rbc {

/// Scale s of the Levenberg shift sigma s I.
enum class ShiftScale {
  mean_abs_diagonal,  ///< mean |K_ii| (continuum: stiffnesses spread over the whole surface)
  max_abs_diagonal,   ///< largest |K_ii| (periodic cell problem)
};

struct ShiftedNewtonOptions {
  /// Converged when the largest block norm of r = grad f + C lambda is <= this (units of
  /// grad f, e.g. pN) ...
  double force_tolerance = 1e-6;
  /// ... and every |c_k| / G_k is below this (ignored without constraints).
  double constraint_tolerance = 1e-10;
  int max_iterations = 100;  ///< Newton iterations per call
  /// Entries per block of x for the residual and step norms (3 = vertex in 3D, 2 in 2D).
  int block_size = 3;
  /// Largest block norm of one Newton step (units of x, e.g. um); infinity = no cap.
  double max_step = std::numeric_limits<double>::infinity();
  int max_line_search = 40;       ///< step halvings before the line search fails
  double armijo = 1e-4;           ///< sufficient-decrease constant of the line search
  double armijo_slack_rel = 0.0;  ///< Armijo test accepts phi rising by this x |phi0| (round-off)
  /// Accept a step that does not raise phi by more than this x |phi0| if it lowers the
  /// residual (the last iterations, where phi changes at round-off level); 0 = off.
  double roundoff_merit_rel = 1e-12;
  double penalty = 1e4;  ///< rho of the merit function (units of f)
  /// Shift: sigma starts at max(initial_shift, shift_memory x last successful sigma),
  /// after a failed factorisation sigma <- max(shift_growth x sigma, retry_shift), at most
  /// max_shift_attempts factorisations per iteration.
  double initial_shift = 1e-8;
  double retry_shift = 1e-4;
  double shift_growth = 10.0;
  double shift_memory = 0.01;  ///< 0 = every iteration starts from initial_shift
  int max_shift_attempts = 30;
  ShiftScale shift_scale = ShiftScale::mean_abs_diagonal;
  /// Chord steps: consecutive iterations that may reuse the last factorisation while each
  /// full step cuts the residual by reuse_contraction (0 = plain Newton).
  int max_factor_reuse = 4;
  double reuse_contraction = 0.25;
  /// Keep the factorisation between calls: the first iteration of the next call is a chord
  /// step on it (the Hessian changes little between time steps or nearby forces).
  bool reuse_across_calls = false;
  /// Krylov correction (0 = off): at most this many projected preconditioned CG iterations
  /// (Gould, Hribar & Nocedal 2001) per Newton iteration turn the shifted (or chord) step into
  /// the exact Newton step of the unshifted d2L on the constraints' tangent space, with the
  /// factorisation of K (and the Schur complement) as the constraint preconditioner. Only the
  /// reduced Hessian Z' d2L Z must be positive definite, not d2L: the Levenberg shift needed
  /// where the constraint curvature (lambda_A d2A at high tension) makes d2L indefinite no
  /// longer slows Newton to a linear rate, and a factorisation may serve many iterations
  /// (assembling d2L each iteration). Negative curvature on the tangent space, no convergence
  /// within the limit, or a step that is no descent direction of the merit: the shifted step
  /// is taken as without the correction. Needs the Hessian at every iteration; not combined
  /// with add_unshifted terms.
  int krylov_iterations = 0;
  /// The correction stops when (g' Pz)/(r' P r) <= krylov_tolerance^2 (g: the quadratic
  /// model's gradient at the step, Pz its projected preconditioned image, r the residual:
  /// the relative error of the step in the preconditioner's norm).
  double krylov_tolerance = 1e-6;
  /// With the correction on, the factorisation is kept for the next iteration (a chord
  /// preconditioner, up to max_factor_reuse times) while the last correction converged in at
  /// most this many CG iterations; reuse_contraction is then not used.
  int krylov_refactor_iterations = 10;
  /// Lagged Hessian: the correction undoes only the shift of the factorised d2L (chord steps
  /// then assemble nothing: a Shamanskii-type chord iteration on the unshifted Hessian of the
  /// last factorisation, refactorised by the reuse_contraction rule); false: the correction
  /// uses the current d2L, assembled every iteration (exact Newton steps).
  bool krylov_lagged_hessian = false;
  /// With the lagged Hessian: once a step of this call has been backtracked or a factorisation
  /// has needed its shift to grow (far from the solution, or d2L indefinite there), the rest of
  /// the call corrects with the current d2L, assembled every iteration (exact Newton steps
  /// preconditioned by the kept factorisation): there the lagged Hessian is a poor model and
  /// costs refactorisations. Near the solution the lagged chord steps stay (they assemble
  /// nothing).
  bool krylov_exact_when_far = false;
  /// With the lagged Hessian, at most this many CG iterations per correction (0 = up to
  /// krylov_iterations). When this cap (below krylov_iterations) ends the correction, the last
  /// iteration's residual is not projected (the solve would only serve the convergence test)
  /// and the multipliers are those of the projection before it.
  /// The lagged correction undoes a shift on a matrix that is itself only a model of d2L:
  /// one CG iteration takes most of the gain (see continuum/newton_solver.hpp).
  int krylov_lagged_iterations = 0;
  /// With the lagged Hessian, chord steps also keep the constraint gradients' solves K^-1 C
  /// from the first step on the current factorisation within a call (m solves saved per
  /// chord step). The Schur complement is then C(x)' K^-1 C_lagged: the step still satisfies
  /// the current linearised constraints exactly, and the Lagrangian row of the KKT matrix is
  /// lagged along with K (a chord step of the whole KKT system). Recomputed after every
  /// factorisation and at every step corrected with the current d2L. A step on a reused K^-1 C
  /// takes one CG iteration of correction at most (its projection is oblique).
  bool krylov_lagged_constraints = false;
  /// The part of the shift (relative to s) the correction keeps: the step is exact for
  /// d2L + krylov_kept_shift s I, so the rigid null modes stay regularised as with the
  /// smallest shift alone (without it a warm and a cold solve at 0 pN end in rotations
  /// 3e-8 apart).
  double krylov_kept_shift = 1e-8;
  /// Round-off floor: after stall_iterations iterations without the best residual halving,
  /// and with the best residual <= floor_factor x force_tolerance, stop converged at the best
  /// iterate (stall_iterations 0 or floor_factor 0 = off).
  int stall_iterations = 0;
  double floor_factor = 1.0;
  SparseCholeskyOptions cholesky;
  CancelCheck cancel;  ///< polled once per iteration (throws Cancelled)
  /// Throws std::invalid_argument naming the quantity, value and expectation.
  void validate() const;
};

/// Typed outcome of a shifted-Newton solve.
enum class NewtonStatus {
  converged,
  max_iterations,
  line_search_failed,
  infeasible_start,
  time_budget,           ///< the caller's deadline passed before convergence
  factorisation_failed,  ///< K stayed indefinite up to the largest shift
};
std::string to_string(NewtonStatus s);
/// The MinimiserStatus (core/lbfgs.hpp) of a shifted-Newton outcome, for callers that report
/// minimiser statuses (the periodic cell problem): each value maps to its namesake, time_budget
/// to max_iterations (MinimiserStatus has no deadline value).
MinimiserStatus minimiser_status(NewtonStatus s);
/// The NewtonStatus of a minimiser outcome (the continuum L-BFGS path): each value to its
/// namesake.
NewtonStatus newton_status(MinimiserStatus s);

/// f, its gradient and the constraints at one point.
struct NewtonPoint {
  double value = 0;
  Eigen::VectorXd grad;    ///< n
  Eigen::VectorXd c;       ///< m constraint values c(x) (0 at feasibility)
  Eigen::MatrixXd c_grad;  ///< n x m, column k = grad c_k
};

struct NewtonProblem {
  /// Evaluates f (and grad f, c, C) at x; returns false (or a non-finite value) outside the
  /// domain. c and C are left empty for an unconstrained problem.
  std::function<bool(const Eigen::VectorXd& x, NewtonPoint& p)> evaluate;
  /// Assembles d2f + sum_k lambda_k d2c_k at x into a matrix the caller owns and returns it
  /// (symmetric, compressed; the lower triangle is read; its pattern must contain the
  /// diagonal and normally stays fixed: it is re-analysed only when its size or nonzero count
  /// changes). Typically a BlockMatrix's matrix() (core/block_pattern.hpp).
  std::function<const Eigen::SparseMatrix<double>&(const Eigen::VectorXd& x,
                                                   const Eigen::VectorXd& lambda)>
      hessian;
  /// Optional: adds terms to the shifted matrix before factorisation (e.g. a drag's fixed
  /// diagonal blocks that should not count in the shift scale).
  std::function<void(Eigen::SparseMatrix<double>& k)> add_unshifted;
  /// Optional: projects the Newton step dx at x (after the KKT solve, before the step cap),
  /// e.g. removes the rigid-body modes an invariant problem does not see, which the tiny
  /// shift alone leaves undetermined once a chord step uses an older factorisation. It must
  /// keep C' dx (constraints invariant under the removed modes).
  std::function<void(const Eigen::VectorXd& x, Eigen::VectorXd& dx)> project_step;
  /// Optional: false if the trial point `to` reached from `from` is infeasible (halved).
  std::function<bool(const Eigen::VectorXd& from, const Eigen::VectorXd& to)> feasible;
  /// Scale G_k of each constraint (m entries; c_k/G_k is the relative violation).
  Eigen::VectorXd constraint_scale;
  /// Optional: the residual's size (largest net force of a vertex, units of grad f) and a
  /// step's (largest vertex displacement, units of x) when the unknowns are not blocks of
  /// block_size (a symmetry-reduced problem, core/reduced_problem.hpp); empty = the largest
  /// block norm of the vector.
  std::function<double(const Eigen::VectorXd& r)> residual_norm;
  std::function<double(const Eigen::VectorXd& dx)> step_norm;
};

/// Per-iteration report.
struct NewtonIterate {
  int iteration = 0;
  double value = 0;                 ///< f
  double residual = 0;              ///< largest block norm of r
  double constraint_violation = 0;  ///< largest |c_k| / G_k
  Eigen::VectorXd relative_c;       ///< c_k / G_k
};

struct NewtonLimitsCore {
  int max_iterations = -1;      ///< < 0: options.max_iterations
  double force_tolerance = -1;  ///< < 0: options.force_tolerance (e.g. a step's dt-scaled one)
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
};

struct ShiftedNewtonResult {
  NewtonStatus status = NewtonStatus::max_iterations;
  int iterations = 0;
  int factorisations = 0;     ///< numeric factorisations, including retries with larger shifts
  int chord_steps = 0;        ///< iterations that reused an earlier factorisation
  int krylov_iterations = 0;  ///< CG iterations of the Krylov correction, summed
  int krylov_fallbacks = 0;   ///< Newton iterations that took the shifted step instead
  double residual = 0;        ///< largest block norm of r at the returned point
  double largest_shift = 0;
  bool at_roundoff_floor = false;
  NewtonPoint point;  ///< f, gradient and constraints at the returned x
};

/// Prepared state of the method for one problem size: the factorisation (symbolic analysis
/// reused while the pattern stays) and, with reuse_across_calls, the last numeric factor.
class ShiftedNewton {
 public:
  explicit ShiftedNewton(const ShiftedNewtonOptions& options);
  /// Solves from x (updated in place to the returned point) and lambda (m, updated).
  ShiftedNewtonResult solve(const NewtonProblem& problem, Eigen::VectorXd& x,
                            Eigen::VectorXd& lambda,
                            const std::function<void(const NewtonIterate&)>& on_iteration = {},
                            const NewtonLimitsCore& limits = {});
  /// Drops a kept factorisation (the next iteration factorises afresh).
  void forget_factorisation() { have_factor_ = false; }
  /// A deep copy, the factorisation included (kept per force by a sweep while this one moves
  /// on to the next force).
  ShiftedNewton clone() const;
  /// Exchanges the whole state (options, analysis, factorisation) with other; no copies.
  void swap(ShiftedNewton& other) noexcept;
  /// Whether a factorisation is held (the next call starts from it with reuse_across_calls).
  bool has_factorisation() const { return have_factor_; }
  /// Factorises the Hessian of pb at (x, lambda), the shift growing from initial_shift as in
  /// an iteration until K is positive definite, and holds it (the next call starts from it with
  /// reuse_across_calls): e.g. at an equilibrium, for later re-solves near it. Adds the
  /// factorisations made to *factorisations (if given); false when no shift made K definite.
  bool factorise_at(const NewtonProblem& pb, const Eigen::VectorXd& x,
                    const Eigen::VectorXd& lambda, int* factorisations = nullptr);
  const ShiftedNewtonOptions& options() const { return options_; }

 private:
  void prepare_pattern(const Eigen::SparseMatrix<double>& h);
  /// Factorises K = h + sigma s I (+ add_unshifted), sigma growing from `sigma` until K is
  /// positive definite (at most max_shift_attempts factorisations, counted in factorisations).
  /// Returns the sigma used (relative to s), or -1 when every attempt failed.
  double factorise_shifted(const NewtonProblem& pb, const Eigen::SparseMatrix<double>& h,
                           double sigma, int& factorisations);
  /// Krylov correction of the shifted step dx (C' dx = -c) to the Newton step of h on the
  /// tangent space; dl: the multiplier increment of the corrected step. Returns the CG
  /// iterations (>= 0) on convergence, -(iterations + 1) on failure (dx, dl then unusable).
  /// h - diag_shift I is the Hessian the step is exact for.
  int krylov_correct(const Eigen::SparseMatrix<double>& h, double diag_shift, int max_its,
                     const Eigen::MatrixXd& c_grad, const Eigen::MatrixXd& ym,
                     const Eigen::FullPivLU<Eigen::MatrixXd>& sc, const Eigen::VectorXd& r,
                     const Eigen::VectorXd& y0, Eigen::VectorXd& dx, Eigen::VectorXd& dl) const;
  ShiftedNewtonOptions options_;
  SparseCholesky cholesky_;
  Eigen::SparseMatrix<double> k_;  ///< shifted copy of the Hessian
  std::vector<int> diag_;          ///< value index of each diagonal entry of k_
  Eigen::Index analysed_rows_ = -1, analysed_nonzeros_ = -1;
  bool have_factor_ = false;
  double shift_hint_ = 0.0;
  int last_krylov_iterations_ = 0;  ///< of the last correction (-1: it failed)
  double factor_shift_ = 0.0;       ///< sigma s of the kept factorisation
  double factor_scale_ = 0.0;       ///< its s
};

/// Largest Euclidean norm over consecutive blocks of block_size entries of v.
double largest_block_norm(const Eigen::VectorXd& v, int block_size);

}  // namespace rbc
