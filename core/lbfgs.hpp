// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Limited-memory BFGS with a feasibility-aware backtracking line search.
//
// Why our own and not a library's (libLBFGS, GSL's bfgs2): the spectrin energy is
// +infinity outside an open domain (a link at or past Lmax, a collapsed face), and the
// line search must treat such a trial as an infeasible step to be shortened, never as a
// number; it must also cap the largest vertex displacement per trial. Neither library
// offers both, and GSL's bfgs2 keeps only one correction pair.
#include <Eigen/Core>
#include <functional>
#include <string>

#include "core/progress.hpp"
#include "core/validation.hpp"

namespace rbc {

/// Largest iteration budget accepted by any solver's options (per solve).
inline constexpr int kMaxIterations = 10000000;

/// Objective: returns the energy at x and writes its gradient into grad (same size as x).
/// Returns +infinity (grad untouched) when x is outside the physical domain.
using Objective = std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd& grad)>;

struct LbfgsOptions {
  int memory = 12;             ///< correction pairs kept
  int max_iterations = 20000;  ///< iterations before giving up
  /// Objective evaluations before giving up (line-search trials included; an iteration
  /// whose trials keep hitting the infeasible domain costs up to max_line_search of them).
  /// 0 = no limit. Stops with MinimiserStatus::max_iterations.
  long long max_evaluations = 0;
  /// Converged when the largest block norm of the gradient (with block = 3: the largest
  /// net vertex force, pN) is below this.
  double force_tolerance = 1e-3;
  int block = 3;  ///< gradient entries per degree of freedom block
  /// Largest block displacement a line-search trial may make (um for positions);
  /// <= 0 means no cap.
  double max_step = 0.0;
  double armijo = 1e-4;      ///< sufficient-decrease constant
  int max_line_search = 60;  ///< trials before the line search gives up
  /// Optional preconditioner: replaces v by P^{-1} v, with P symmetric positive definite
  /// approximating the Hessian. It is the two-loop recursion's initial inverse Hessian
  /// (in place of the scalar s.y/y.y), so a good P makes the steps nearly Newton steps.
  std::function<void(Eigen::VectorXd& v)> precondition;
  /// Polled once per iteration; returning true stops the minimiser by throwing Cancelled.
  CancelCheck cancel;
  /// Optional: the gradient's size for the convergence test (default: its largest block
  /// norm) and a step's for max_step (default: its largest block norm), for unknowns that are
  /// not blocks (a symmetry-reduced problem: core/reduced_problem.hpp).
  std::function<double(const Eigen::VectorXd& g)> residual_norm;
  std::function<double(const Eigen::VectorXd& d)> step_norm;
  /// Throws rbc::InvalidParameter: memory in [1, 1000], max_iterations in [1, kMaxIterations],
  /// force_tolerance finite and > 0, block >= 1, max_step finite, armijo in (0, 1),
  /// max_line_search in [1, 1000].
  void validate() const {
    require_integer_in_range("L-BFGS memory", memory, 1, 1000);
    require_integer_in_range("max iterations", max_iterations, 1, kMaxIterations);
    require_finite_in_range("force tolerance", "", force_tolerance, 0.0, kUnbounded);
    require_integer_in_range("L-BFGS block size", block, 1, 1000);
    require_finite_in_range("L-BFGS largest step", "", max_step, -kUnbounded, kUnbounded);
    require_finite_in_range("Armijo constant", "", armijo, 0.0, 1.0, Ends::open_open);
    require_integer_in_range("line-search trials", max_line_search, 1, 1000);
  }
};

enum class MinimiserStatus {
  converged,
  max_iterations,
  line_search_failed,
  infeasible_start,
  /// A Newton-type minimiser found no definite (shifted) factorisation of its Hessian. L-BFGS
  /// never returns it; the cell problem (homogenise/periodic_network.hpp) does.
  factorisation_failed,
};

std::string to_string(MinimiserStatus status);

struct MinimiserResult {
  MinimiserStatus status = MinimiserStatus::max_iterations;
  int iterations = 0;
  int evaluations = 0;
  double energy = 0.0;    ///< objective at the returned x
  double residual = 0.0;  ///< largest gradient block norm at the returned x
  bool converged() const { return status == MinimiserStatus::converged; }
};

/// Called after each iteration with (iteration, energy, residual); return false to stop.
using IterationMonitor = std::function<bool(int iteration, double energy, double residual)>;

/// Largest Euclidean norm over consecutive blocks of `block` entries.
double max_block_norm(const Eigen::VectorXd& v, int block);

/// Minimises f from x (updated in place). Never returns a point where f is infinite.
MinimiserResult minimise_lbfgs(const Objective& f, Eigen::VectorXd& x, const LbfgsOptions& options,
                               const IterationMonitor& monitor = {});

}  // namespace rbc
