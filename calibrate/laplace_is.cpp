// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/laplace_is.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>

namespace rbc {

namespace {
constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr int kIsDrawPurpose = 101;      // stream purpose: proposal draw i
constexpr int kIsResamplePurpose = 102;  // stream purpose: systematic resampling

double logistic_of(double z) {
  return 1.0 / (1.0 + std::exp(-z));
}
/// log s(z) + log(1 - s(z)) = -|z| - 2 log(1 + exp(-|z|)), stable for large |z|.
double log_jacobian_term(double z) {
  return -std::abs(z) - 2.0 * std::log1p(std::exp(-std::abs(z)));
}

double is_log_sum_exp(const Eigen::VectorXd& a) {
  const double m = a.maxCoeff();
  if (!(m > -kInfinity)) return -kInfinity;
  return m + std::log((a.array() - m).exp().sum());
}
}  // namespace

void LaplaceIsOptions::validate() const {
  if (samples < 10)
    throw std::invalid_argument("--is-samples " + std::to_string(samples) +
                                ": expected at least 10");
  if (!(nu > 2) || !std::isfinite(nu))
    throw std::invalid_argument("Student-t degrees of freedom must be > 2, got " +
                                std::to_string(nu));
  if (!(inflation > 0) || !std::isfinite(inflation))
    throw std::invalid_argument("proposal inflation must be > 0, got " + std::to_string(inflation));
  if (rounds < 1 || rounds > samples)
    throw std::invalid_argument("--is-rounds " + std::to_string(rounds) +
                                ": expected 1 to the number of importance samples (" +
                                std::to_string(samples) + ")");
  if (max_newton_steps < 0)
    throw std::invalid_argument("Newton steps must be >= 0, got " +
                                std::to_string(max_newton_steps));
}

Eigen::VectorXd box_to_logit(const PriorBox& box, const Eigen::VectorXd& theta) {
  Eigen::VectorXd z(theta.size());
  for (int k = 0; k < theta.size(); ++k) {
    const double u = (theta(k) - box.lower[k]) / (box.upper[k] - box.lower[k]);
    z(k) = std::log(u / (1.0 - u));
  }
  return z;
}

Eigen::VectorXd logit_to_box(const PriorBox& box, const Eigen::VectorXd& z) {
  Eigen::VectorXd t(z.size());
  for (int k = 0; k < z.size(); ++k) {
    // Keep theta strictly inside the box where s(z) rounds to 0 or 1.
    const double w = box.upper[k] - box.lower[k];
    const double u = std::clamp(logistic_of(z(k)), 1e-15, 1.0 - 1e-15);
    t(k) = box.lower[k] + w * u;
  }
  return t;
}

double logit_log_prior(const Eigen::VectorXd& z) {
  double s = 0;
  for (int k = 0; k < z.size(); ++k) s += log_jacobian_term(z(k));
  return s;
}

double student_t_log_density(const Eigen::VectorXd& x, const Eigen::VectorXd& m,
                             const Eigen::MatrixXd& chol, double nu) {
  const int d = static_cast<int>(x.size());
  const Eigen::VectorXd y = chol.triangularView<Eigen::Lower>().solve(x - m);
  const double log_det = 2.0 * chol.diagonal().array().log().sum();
  return std::lgamma(0.5 * (nu + d)) - std::lgamma(0.5 * nu) - 0.5 * d * std::log(nu * M_PI) -
         0.5 * log_det - 0.5 * (nu + d) * std::log1p(y.squaredNorm() / nu);
}

double weighted_quantile(const Eigen::VectorXd& x, const Eigen::VectorXd& w, double q) {
  const int n = static_cast<int>(x.size());
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return x(a) < x(b); });
  // Midpoint CDF: sample j (sorted) sits at c_j = (cumulative mass before it) + w_j / 2.
  double before = 0, prev_c = 0, prev_x = x(order[0]);
  for (int j = 0; j < n; ++j) {
    const double wj = w(order[j]);
    const double c = before + 0.5 * wj;
    if (q <= c) {
      if (j == 0 || c <= prev_c) return x(order[j]);
      const double f = (q - prev_c) / (c - prev_c);
      return prev_x + f * (x(order[j]) - prev_x);
    }
    if (wj > 0) {
      prev_c = c;
      prev_x = x(order[j]);
    }
    before += wj;
  }
  return prev_x;
}

int laplace_is_block(int samples) {
  return std::max(10, (samples + 19) / 20);
}

LaplaceIsResult run_laplace_is(const GradientTarget& target, const Likelihood& likelihood,
                               const PriorBox& prior, const LaplaceIsOptions& options,
                               const Executor& executor_in) {
  return run_laplace_is(target, likelihood, prior, options, executor_in, {});
}

LaplaceIsResult run_laplace_is(const GradientTarget& target, const Likelihood& likelihood,
                               const PriorBox& prior, const LaplaceIsOptions& options,
                               const Executor& executor_in,
                               const LaplaceIsContinuation& continuation) {
  options.validate();
  prior.validate();
  const auto t0 = std::chrono::steady_clock::now();
  const int d = prior.dimension();
  const int S = options.samples;
  LaplaceIsResult r;
  Eigen::VectorXd width(d);
  for (int k = 0; k < d; ++k) width(k) = prior.upper[k] - prior.lower[k];
  const LaplaceIsState* resume = continuation.resume;
  if (resume) {
    const bool shapes = resume->z.size() == d && resume->point.gradient.size() == d &&
                        resume->point.information.rows() == d &&
                        resume->point.information.cols() == d && resume->point.ok &&
                        resume->draws_done >= 0 && resume->draws_done <= S &&
                        (resume->mode_found || resume->draws_done == 0) &&
                        resume->draw_log_likelihood.size() == resume->draws_done &&
                        static_cast<int>(resume->draw_states.size()) == resume->draws_done;
    if (!shapes)
      throw std::invalid_argument("laplace-is: the state to continue from is of another problem");
  }
  LaplaceIsState state;  // what the checkpoints hand out
  const auto checkpoint = [&] {
    if (continuation.checkpoint) continuation.checkpoint(state);
  };

  // --- mode search in z -------------------------------------------------------------------
  struct ZPoint {
    GradientPoint p;
    double log_post = -kInfinity;
    Eigen::VectorXd grad;
    Eigen::MatrixXd hess;
  };
  // The point's derivatives in z from its evaluation in theta (also for a stored point).
  const auto in_z = [&](const Eigen::VectorXd& z, GradientPoint p) {
    ZPoint out;
    out.p = std::move(p);
    if (!out.p.ok || !std::isfinite(out.p.log_likelihood)) return out;
    out.log_post = out.p.log_likelihood + logit_log_prior(z);
    Eigen::VectorXd s(d), dtheta(d);
    for (int k = 0; k < d; ++k) {
      s(k) = logistic_of(z(k));
      dtheta(k) = width(k) * s(k) * (1.0 - s(k));
    }
    out.grad = dtheta.cwiseProduct(out.p.gradient) + (1.0 - 2.0 * s.array()).matrix();
    out.hess = dtheta.asDiagonal() * out.p.information * dtheta.asDiagonal();
    for (int k = 0; k < d; ++k) out.hess(k, k) += 2.0 * s(k) * (1.0 - s(k));
    return out;
  };
  const auto evaluate_z = [&](const Eigen::VectorXd& z, const WarmState& warm) {
    throw_if_cancelled(options.cancel);
    GradientPoint p = target(logit_to_box(prior, z), warm);
    ++r.gradient_evaluations;
    return in_z(z, std::move(p));
  };
  Eigen::VectorXd z = Eigen::VectorXd::Zero(d);
  ZPoint cur;
  const auto record_point = [&](bool mode_found) {
    state.mode_found = mode_found;
    state.newton_steps = r.newton_steps;
    state.gradient_evaluations = r.gradient_evaluations;
    state.z = z;
    state.point = cur.p;
  };
  if (resume) {
    z = resume->z;
    cur = in_z(z, resume->point);
    r.newton_steps = resume->newton_steps;
    r.gradient_evaluations = resume->gradient_evaluations;
    if (!(cur.log_post > -kInfinity))
      throw std::invalid_argument("laplace-is: the state to continue from has no log likelihood");
  } else {
    cur = evaluate_z(z, {});
    if (!(cur.log_post > -kInfinity))
      throw std::runtime_error("laplace-is: the likelihood failed at the prior centre");
    record_point(false);
    checkpoint();
  }
  if (!resume || !resume->mode_found) {
    for (int it = r.newton_steps; it < options.max_newton_steps; ++it) {
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(cur.hess);
      const Eigen::VectorXd step = ldlt.solve(cur.grad);
      if (!step.allFinite()) break;
      if (cur.grad.dot(step) < options.mode_tolerance) break;
      double a = 1.0;
      bool moved = false;
      for (int h = 0; h < 10; ++h, a *= 0.5) {
        const Eigen::VectorXd zn = z + a * step;
        ZPoint next = evaluate_z(zn, cur.p.state);
        if (next.log_post > cur.log_post) {
          z = zn;
          cur = std::move(next);
          moved = true;
          break;
        }
      }
      ++r.newton_steps;
      if (!moved) break;
      record_point(false);
      checkpoint();
    }
    record_point(true);
    checkpoint();
  } else {
    record_point(true);
  }
  r.mode_z = z;
  r.mode_theta = logit_to_box(prior, z);
  r.covariance_z = cur.hess.inverse();

  // --- proposals: round 0 the Laplace Student-t, each later one refit to the weighted draws --
  struct Proposal {
    Eigen::VectorXd mean;
    Eigen::MatrixXd chol;  // lower Cholesky factor of the Student-t's scale matrix
  };
  std::vector<Proposal> proposals;
  {
    const Eigen::LLT<Eigen::MatrixXd> llt(options.inflation * r.covariance_z);
    if (llt.info() != Eigen::Success)
      throw std::runtime_error("laplace-is: the Laplace covariance is not positive definite");
    proposals.push_back({z, llt.matrixL()});
  }
  const int rounds = options.rounds;
  const auto round_begin = [&](int t) {
    return static_cast<int>(static_cast<long long>(S) * t / rounds);
  };
  std::vector<ChainTask> tasks(S);
  Eigen::MatrixXd zs(S, d);
  const int nu_int = static_cast<int>(std::lround(options.nu));
  const bool integer_nu = std::abs(options.nu - nu_int) < 1e-12;
  const auto draw = [&](int i, const Proposal& q) {
    NormalStream rng(stream_seed(options.seed, 0, i, kIsDrawPurpose));
    Eigen::VectorXd y(d);
    for (int k = 0; k < d; ++k) y(k) = rng.normal();
    double chi2 = 0;
    if (integer_nu) {
      for (int k = 0; k < nu_int; ++k) chi2 += std::pow(rng.normal(), 2);
    } else {
      // chi-square(nu) = 2 Gamma(nu/2): Marsaglia-Tsang would do; the default nu is integer.
      std::gamma_distribution<double> g(0.5 * options.nu, 2.0);
      std::mt19937_64 gen(stream_seed(options.seed, 1, i, kIsDrawPurpose));
      chi2 = g(gen);
    }
    const Eigen::VectorXd zi = q.mean + q.chol * y * std::sqrt(options.nu / chi2);
    zs.row(i) = zi.transpose();
    const Eigen::VectorXd th = logit_to_box(prior, zi);
    tasks[i].index = i;
    tasks[i].theta.assign(th.data(), th.data() + d);
    tasks[i].state = cur.p.state;  // warm start from the mode's equilibria, in every block
  };
  // log w_i = log L + log prior - log q_mix over the first n draws, q_mix the deterministic
  // mixture of the proposals so far, each weighted by its share of those draws.
  const auto log_weights = [&](int n) {
    Eigen::VectorXd logw(n);
    const int used = static_cast<int>(proposals.size());
    Eigen::VectorXd logq(used);
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(tasks[i].log_likelihood)) {
        logw(i) = -kInfinity;
        continue;
      }
      const Eigen::VectorXd zi = zs.row(i).transpose();
      for (int t = 0; t < used; ++t)
        logq(t) = student_t_log_density(zi, proposals[size_t(t)].mean, proposals[size_t(t)].chol,
                                        options.nu) +
                  std::log(static_cast<double>(round_begin(t + 1) - round_begin(t)) / n);
      logw(i) = tasks[i].log_likelihood + logit_log_prior(zi) - is_log_sum_exp(logq);
    }
    return logw;
  };
  StageSetup setup;
  setup.stage = 0;
  setup.beta = 1;
  setup.chain_length = 0;
  setup.seed = options.seed;
  const Executor executor = executor_in ? executor_in : omp_executor(prior, likelihood);
  // The draws evaluated before (a continued run) are taken from the state; the others are
  // evaluated block by block, a block never crossing into the next round.
  const int resumed = resume ? resume->draws_done : 0;
  if (resume) state.counts = resume->counts;
  const int block = continuation.checkpoint
                        ? (continuation.block > 0 ? continuation.block : laplace_is_block(S))
                        : S;
  const auto record_draws = [&](int upto) {
    state.draws_done = upto;
    state.draw_log_likelihood.resize(upto);
    state.draw_states.resize(size_t(upto));
    for (int i = 0; i < upto; ++i) {
      state.draw_log_likelihood(i) = tasks[i].log_likelihood;
      state.draw_states[size_t(i)] = tasks[i].state;
    }
  };
  for (int t = 0; t < rounds; ++t) {
    const int begin = round_begin(t), stop = round_begin(t + 1);
    for (int i = begin; i < stop; ++i) draw(i, proposals.back());
    for (int i = begin; i < std::min(stop, resumed); ++i) {
      tasks[i].log_likelihood = resume->draw_log_likelihood(i);
      tasks[i].state = resume->draw_states[size_t(i)];
    }
    int done = std::max(begin, std::min(stop, resumed));
    while (done < stop) {
      throw_if_cancelled(options.cancel);
      const int end = std::min(stop, (done / block + 1) * block);
      std::vector<ChainTask> part(std::make_move_iterator(tasks.begin() + done),
                                  std::make_move_iterator(tasks.begin() + end));
      // An executor finds a task by its index in the vector it is given (the MPI master does);
      // an evaluation (chain_length 0) draws no random numbers, so the index changes nothing
      // else.
      for (size_t k = 0; k < part.size(); ++k) part[k].index = static_cast<int>(k);
      executor(setup, part);
      for (int i = done; i < end; ++i) {
        tasks[i] = std::move(part[size_t(i - done)]);
        state.counts += tasks[i].counts;
      }
      done = end;
      if (continuation.checkpoint) {
        record_draws(done);
        checkpoint();
      }
    }
    if (t + 1 == rounds) break;
    // Refit: the next proposal's location and scale are the weighted mean and covariance of
    // all draws so far, blended with the last scale while the draws are few (weight
    // min(1, ESS / (10 d))), so that a handful of dominant draws cannot collapse it.
    const Eigen::VectorXd logw = log_weights(stop);
    const double lse = is_log_sum_exp(logw);
    Proposal next = proposals.back();
    if (lse > -kInfinity) {
      const Eigen::VectorXd w = (logw.array() - lse).exp().matrix();
      const Eigen::MatrixXd zt = zs.topRows(stop);
      const Eigen::VectorXd mean = zt.transpose() * w;
      const Eigen::MatrixXd centred = zt.rowwise() - mean.transpose();
      const Eigen::MatrixXd cov = centred.transpose() * w.asDiagonal() * centred;
      const double lambda = std::min(1.0, (1.0 / w.squaredNorm()) / (10.0 * d));
      const Eigen::MatrixXd last = proposals.back().chol * proposals.back().chol.transpose();
      const Eigen::LLT<Eigen::MatrixXd> llt(lambda * cov + (1.0 - lambda) * last);
      if (llt.info() == Eigen::Success && mean.allFinite()) next = {mean, llt.matrixL()};
    }
    r.round_ess.push_back(lse > -kInfinity ? 1.0 / (logw.array() - lse).exp().square().sum() : 0.0);
    proposals.push_back(std::move(next));
  }
  ForwardCounts draw_counts = state.counts;

  // --- weights ----------------------------------------------------------------------------
  r.draws.resize(S, d);
  r.draw_log_likelihood.resize(S);
  r.draw_states.resize(S);
  const Eigen::VectorXd logw = log_weights(S);
  for (int i = 0; i < S; ++i) {
    for (int k = 0; k < d; ++k) r.draws(i, k) = tasks[i].theta[k];
    r.draw_log_likelihood(i) = tasks[i].log_likelihood;
    r.draw_states[i] = std::move(tasks[i].state);
  }
  r.counts = draw_counts;
  const double lse = is_log_sum_exp(logw);
  if (!(lse > -kInfinity)) throw std::runtime_error("laplace-is: every importance weight is zero");
  r.weights = (logw.array() - lse).exp().matrix();
  r.log_evidence = lse - std::log(static_cast<double>(S));
  // Delta method: var(log mean w) ~ var(w) / (S mean(w)^2), with w scaled by exp(-lse).
  const double mean_w = 1.0 / S;  // of the normalised weights
  const double var_w = (r.weights.array() - mean_w).square().sum() / std::max(1, S - 1);
  r.log_evidence_sd = std::sqrt(var_w / S) / mean_w;
  r.ess = 1.0 / r.weights.squaredNorm();

  // --- systematic resampling --------------------------------------------------------------
  NormalStream rng(stream_seed(options.seed, 0, 0, kIsResamplePurpose));
  const double u0 = rng.uniform() / S;
  r.samples.resize(S, d);
  r.log_likelihood.resize(S);
  r.states.resize(S);
  double cum = r.weights(0);
  int j = 0;
  for (int i = 0; i < S; ++i) {
    const double u = u0 + static_cast<double>(i) / S;
    while (u > cum && j < S - 1) cum += r.weights(++j);
    r.samples.row(i) = r.draws.row(j);
    r.log_likelihood(i) = r.draw_log_likelihood(j);
    r.states[i] = r.draw_states[j];
  }
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace rbc
