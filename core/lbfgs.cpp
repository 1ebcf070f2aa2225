// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/lbfgs.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <vector>

namespace rbc {

std::string to_string(MinimiserStatus status) {
  switch (status) {
    case MinimiserStatus::converged:
      return "converged";
    case MinimiserStatus::max_iterations:
      return "iteration limit reached";
    case MinimiserStatus::line_search_failed:
      return "line search failed";
    case MinimiserStatus::infeasible_start:
      return "infeasible starting point";
    case MinimiserStatus::factorisation_failed:
      return "factorisation failed";
  }
  return "unknown";
}

double max_block_norm(const Eigen::VectorXd& v, int block) {
  double worst = 0.0;
  for (Eigen::Index i = 0; i + block <= v.size(); i += block)
    worst = std::max(worst, v.segment(i, block).norm());
  return worst;
}

MinimiserResult minimise_lbfgs(const Objective& f, Eigen::VectorXd& x, const LbfgsOptions& opt,
                               const IterationMonitor& monitor) {
  MinimiserResult res;
  const Eigen::Index n = x.size();
  Eigen::VectorXd g(n), g_new(n), x_new(n), d(n);
  double fx = f(x, g);
  res.evaluations = 1;
  if (!std::isfinite(fx)) {
    res.status = MinimiserStatus::infeasible_start;
    res.energy = fx;
    return res;
  }
  struct Pair {
    Eigen::VectorXd s, y;
    double rho;
  };
  std::deque<Pair> history;
  std::vector<double> alpha(opt.memory);
  auto residual_norm = [&](const Eigen::VectorXd& v) {
    return opt.residual_norm ? opt.residual_norm(v) : max_block_norm(v, opt.block);
  };
  double residual = residual_norm(g);
  for (int it = 0;; ++it) {
    throw_if_cancelled(opt.cancel);
    res.iterations = it;
    res.energy = fx;
    res.residual = residual;
    if (residual < opt.force_tolerance) {
      res.status = MinimiserStatus::converged;
      return res;
    }
    if (it >= opt.max_iterations ||
        (opt.max_evaluations > 0 && res.evaluations >= opt.max_evaluations)) {
      res.status = MinimiserStatus::max_iterations;
      return res;
    }
    // Two-loop recursion: d = -H g.
    d = -g;
    for (int k = static_cast<int>(history.size()) - 1; k >= 0; --k) {
      alpha[k] = history[k].rho * history[k].s.dot(d);
      d -= alpha[k] * history[k].y;
    }
    if (opt.precondition) {
      opt.precondition(d);
    } else if (!history.empty()) {
      const auto& last = history.back();
      d *= last.s.dot(last.y) / last.y.squaredNorm();
    } else {
      // First step: move the largest block by at most a modest amount.
      d *= 1.0 / std::max(residual, 1e-300) * (opt.max_step > 0 ? opt.max_step : 1.0) * 0.1;
    }
    for (size_t k = 0; k < history.size(); ++k) {
      const double beta = history[k].rho * history[k].y.dot(d);
      d += (alpha[k] - beta) * history[k].s;
    }
    double slope = g.dot(d);
    if (!(slope < 0.0)) {  // not a descent direction: restart with steepest descent
      history.clear();
      d = -g * (0.1 / std::max(residual, 1e-300)) * (opt.max_step > 0 ? opt.max_step : 1.0);
      slope = g.dot(d);
    }
    double step = 1.0;
    if (opt.max_step > 0.0) {
      const double longest = opt.step_norm ? opt.step_norm(d) : max_block_norm(d, opt.block);
      if (longest > opt.max_step) step = opt.max_step / longest;
    }
    // Backtracking: infeasible trials are halved, Armijo failures interpolated.
    bool accepted = false;
    double f_new = 0.0;
    for (int ls = 0; ls < opt.max_line_search; ++ls) {
      if (opt.max_evaluations > 0 && res.evaluations >= opt.max_evaluations) {
        res.status = MinimiserStatus::max_iterations;  // budget spent inside the line search
        return res;
      }
      x_new = x + step * d;
      f_new = f(x_new, g_new);
      ++res.evaluations;
      if (!std::isfinite(f_new)) {
        step *= 0.3;
        continue;
      }
      if (f_new <= fx + opt.armijo * step * slope) {
        accepted = true;
        break;
      }
      // Quadratic model through f(0), f'(0), f(step); keep within [0.1, 0.5] step.
      const double denom = 2.0 * (f_new - fx - slope * step);
      double trial = denom > 0 ? -slope * step * step / denom : 0.5 * step;
      step = std::clamp(trial, 0.1 * step, 0.5 * step);
    }
    if (!accepted) {
      if (!history.empty()) {  // retry once from steepest descent before giving up
        history.clear();
        continue;
      }
      res.status = MinimiserStatus::line_search_failed;
      return res;
    }
    Pair p{x_new - x, g_new - g, 0.0};
    const double sy = p.s.dot(p.y);
    x.swap(x_new);
    g.swap(g_new);
    fx = f_new;
    residual = residual_norm(g);
    if (sy > 1e-16 * p.y.squaredNorm()) {  // keep the update positive definite
      p.rho = 1.0 / sy;
      history.push_back(std::move(p));
      if (static_cast<int>(history.size()) > opt.memory) history.pop_front();
    }
    if (monitor && !monitor(it + 1, fx, residual)) {
      res.iterations = it + 1;
      res.energy = fx;
      res.residual = residual;
      res.status = MinimiserStatus::max_iterations;
      return res;
    }
  }
}

}  // namespace rbc
