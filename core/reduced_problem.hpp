// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A problem over 3N vertex coordinates restricted to the configurations symmetric under a
// mirror group (core/mirror_symmetry.hpp): x = P q. The reduced problem evaluates the full one
// at P q and returns the reduced gradient P' grad f, the reduced constraint gradients P' C and
// the reduced Hessian P' H P, so Newton's method or L-BFGS on it take the steps the full method
// would take restricted to symmetric states, with |G| times fewer unknowns.
#include <functional>
#include <memory>

#include "core/lbfgs.hpp"
#include "core/mirror_symmetry.hpp"
#include "core/shifted_newton.hpp"

namespace rbc {

/// State a reduced problem keeps between calls: the P'HP map of the Hessian's pattern. Give
/// the same cache to every reduce_newton_problem of one solver (one per force of a
/// continuation) and the map is built once.
struct ReducedProblemCache {
  std::unique_ptr<ReducedMatrix> map;
};

/// The shifted-Newton problem of `full` on q (core/shifted_newton.hpp). Its residual and step
/// norms are the full problem's per-vertex ones (largest net vertex force, largest vertex
/// displacement; `full` must use blocks of 3 per vertex). full.add_unshifted is not supported
/// (std::invalid_argument); full.project_step is applied to P dq and the result's symmetric
/// part kept. `full` and `reduction` are copied / shared: they may go out of scope.
/// P' H P assembled directly (e.g. from one element per orbit) at the full symmetric state x
/// with multipliers lambda; replaces reducing full.hessian.
using ReducedHessian = std::function<const Eigen::SparseMatrix<double>&(
    const Eigen::VectorXd& x, const Eigen::VectorXd& lambda)>;

/// The full problem's value, constraints and gradients at a symmetric state x = P q, valid
/// only there (e.g. from one element per orbit): its gradients need not be the full ones, only
/// their reductions P' g and P' C must be; replaces full.evaluate in the reduced evaluation.
using SymmetricEvaluate = std::function<bool(const Eigen::VectorXd& x, NewtonPoint& p)>;

NewtonProblem reduce_newton_problem(const NewtonProblem& full,
                                    std::shared_ptr<const SymmetryReduction> reduction,
                                    std::shared_ptr<ReducedProblemCache> cache = nullptr,
                                    ReducedHessian reduced_hessian = {},
                                    SymmetricEvaluate symmetric_evaluate = {});

/// The L-BFGS objective f(P q) with gradient P' grad f (core/lbfgs.hpp).
Objective reduce_objective(Objective full, std::shared_ptr<const SymmetryReduction> reduction);

/// L-BFGS options for a reduced objective: the convergence test and the step cap measure the
/// full per-vertex force and displacement (LbfgsOptions::residual_norm, step_norm).
LbfgsOptions reduce_lbfgs_options(LbfgsOptions options,
                                  std::shared_ptr<const SymmetryReduction> reduction);

}  // namespace rbc
