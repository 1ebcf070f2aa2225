// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/reduced_problem.hpp"

#include <stdexcept>

namespace rbc {

NewtonProblem reduce_newton_problem(const NewtonProblem& full,
                                    std::shared_ptr<const SymmetryReduction> reduction,
                                    std::shared_ptr<ReducedProblemCache> cache,
                                    ReducedHessian reduced_hessian,
                                    SymmetricEvaluate symmetric_evaluate) {
  if (!reduction) throw std::invalid_argument("reduce_newton_problem: no reduction given");
  if (full.add_unshifted)
    throw std::invalid_argument("reduce_newton_problem: add_unshifted terms are not supported");
  // Scratch shared by the callbacks: the full point and the P' H P map (built on first use,
  // rebuilt only if the full Hessian's pattern changes).
  struct State {
    NewtonPoint point;
    std::shared_ptr<ReducedProblemCache> cache;
  };
  auto st = std::make_shared<State>();
  st->cache = cache ? std::move(cache) : std::make_shared<ReducedProblemCache>();
  const std::shared_ptr<const SymmetryReduction> red = std::move(reduction);
  NewtonProblem pb;
  SymmetricEvaluate at_symmetric =
      symmetric_evaluate ? std::move(symmetric_evaluate) : full.evaluate;
  pb.evaluate = [at_symmetric, red, st](const Eigen::VectorXd& q, NewtonPoint& p) {
    if (!at_symmetric(expand(*red, q), st->point)) return false;
    p.value = st->point.value;
    if (!std::isfinite(p.value)) return false;
    p.grad = reduce(*red, st->point.grad);
    p.c = st->point.c;
    p.c_grad = st->point.c_grad.size() ? reduce(*red, st->point.c_grad) : Eigen::MatrixXd();
    return true;
  };
  if (reduced_hessian)
    pb.hessian = [red, h = std::move(reduced_hessian)](
                     const Eigen::VectorXd& q,
                     const Eigen::VectorXd& lambda) -> const Eigen::SparseMatrix<double>& {
      return h(expand(*red, q), lambda);
    };
  else
    pb.hessian = [full, red, st](
                     const Eigen::VectorXd& q,
                     const Eigen::VectorXd& lambda) -> const Eigen::SparseMatrix<double>& {
      const Eigen::SparseMatrix<double>& h = full.hessian(expand(*red, q), lambda);
      std::unique_ptr<ReducedMatrix>& map = st->cache->map;
      if (!map || !map->matches(h)) map = std::make_unique<ReducedMatrix>(*red, h);
      return map->reduce(h);
    };
  if (full.project_step)
    pb.project_step = [full, red](const Eigen::VectorXd& q, Eigen::VectorXd& dq) {
      Eigen::VectorXd dx = expand(*red, dq);
      full.project_step(expand(*red, q), dx);
      dq = symmetric_part(*red, dx);
    };
  if (full.feasible)
    pb.feasible = [full, red](const Eigen::VectorXd& from, const Eigen::VectorXd& to) {
      return full.feasible(expand(*red, from), expand(*red, to));
    };
  pb.constraint_scale = full.constraint_scale;
  pb.residual_norm = [red](const Eigen::VectorXd& r) {
    return largest_vertex_norm_of_reduced(*red, r);
  };
  pb.step_norm = [red](const Eigen::VectorXd& d) {
    return largest_vertex_norm_of_expanded(*red, d);
  };
  return pb;
}

Objective reduce_objective(Objective full, std::shared_ptr<const SymmetryReduction> reduction) {
  if (!reduction) throw std::invalid_argument("reduce_objective: no reduction given");
  auto g = std::make_shared<Eigen::VectorXd>();
  return [full = std::move(full), red = std::move(reduction), g](const Eigen::VectorXd& q,
                                                                 Eigen::VectorXd& gq) {
    const double e = full(expand(*red, q), *g);
    if (std::isfinite(e)) gq = reduce(*red, *g);
    return e;
  };
}

LbfgsOptions reduce_lbfgs_options(LbfgsOptions o,
                                  std::shared_ptr<const SymmetryReduction> reduction) {
  if (!reduction) throw std::invalid_argument("reduce_lbfgs_options: no reduction given");
  o.residual_norm = [reduction](const Eigen::VectorXd& g) {
    return largest_vertex_norm_of_reduced(*reduction, g);
  };
  o.step_norm = [reduction](const Eigen::VectorXd& d) {
    return largest_vertex_norm_of_expanded(*reduction, d);
  };
  return o;
}

}  // namespace rbc
