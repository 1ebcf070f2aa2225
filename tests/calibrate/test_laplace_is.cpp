// SPDX-License-Identifier: GPL-3.0-or-later
// The Laplace-IS sampler (calibrate/laplace_is.hpp) on targets known in closed form:
// a linear-Gaussian likelihood under a wide uniform box (posterior N(m, P^-1) and evidence in
// closed form, box truncation below 1e-20), where TMCMC is run too; and a target flat in the
// box, whose posterior is the uniform box (a Kolmogorov-Smirnov test on the weighted draws).
// Each comparison allows 4 Monte Carlo standard errors (two-sided false-alarm rate 6e-5 per
// check for a normal estimator).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "calibrate/laplace_is.hpp"
#include "calibrate/tmcmc.hpp"

namespace rbc {
namespace {

/// y = A theta + noise, noise ~ N(0, diag(s^2)); log L = -1/2 |(y - A theta)/s|^2.
struct LinearGaussian {
  Eigen::MatrixXd A{{1.0, 0.5}, {0.3, -1.2}, {2.0, 0.4}};
  Eigen::VectorXd y{{2.1, 1.3, 3.0}};
  Eigen::VectorXd s{{0.4, 0.5, 0.6}};
  PriorBox box{{-10.0, -8.0}, {10.0, 12.0}};
  Eigen::MatrixXd information() const {
    return A.transpose() * s.array().square().inverse().matrix().asDiagonal() * A;
  }
  Eigen::VectorXd mean() const {
    const Eigen::VectorXd b = A.transpose() * (y.array() / s.array().square()).matrix();
    return information().ldlt().solve(b);
  }
  double log_l(const Eigen::VectorXd& t) const {
    return -0.5 * ((y - A * t).array() / s.array()).square().sum();
  }
  Eigen::VectorXd gradient(const Eigen::VectorXd& t) const {
    return A.transpose() * ((y - A * t).array() / s.array().square()).matrix();
  }
  /// log integral (1/V) L dtheta over R^d (the box holds all but < 1e-20 of it).
  double log_evidence() const {
    const Eigen::MatrixXd P = information();
    return log_l(mean()) + 0.5 * 2 * std::log(2 * M_PI) - 0.5 * std::log(P.determinant()) -
           box.log_volume();
  }
  GradientTarget target() const {
    return [this](const Eigen::VectorXd& t, const WarmState&) {
      GradientPoint p;
      p.ok = true;
      p.log_likelihood = log_l(t);
      p.gradient = gradient(t);
      p.information = information();
      return p;
    };
  }
  FunctionLikelihood likelihood() const {
    return FunctionLikelihood(
        2, [this](std::span<const double> t) { return log_l(Eigen::Vector2d(t[0], t[1])); });
  }
};

/// The weighted 5, 50 and 95 % quantiles of each coordinate equal the closed-form posterior's
/// within 4 standard errors of a weighted sample quantile, sqrt(q (1 - q)) / (density at x_q
/// sqrt(ESS)).
void expect_closed_form_quantiles(const LinearGaussian& g, const LaplaceIsResult& r) {
  const Eigen::VectorXd m = g.mean();
  const Eigen::VectorXd sd = g.information().inverse().diagonal().cwiseSqrt();
  for (int k = 0; k < 2; ++k) {
    const Eigen::VectorXd x = r.draws.col(k);
    const double se50 = 1.2533 * sd(k) / std::sqrt(r.ess);
    const double se05 = std::sqrt(0.05 * 0.95) / 0.10314 * sd(k) / std::sqrt(r.ess);
    EXPECT_NEAR(weighted_quantile(x, r.weights, 0.5), m(k), 4 * se50) << k;
    EXPECT_NEAR(weighted_quantile(x, r.weights, 0.05), m(k) - 1.6449 * sd(k), 4 * se05) << k;
    EXPECT_NEAR(weighted_quantile(x, r.weights, 0.95), m(k) + 1.6449 * sd(k), 4 * se05) << k;
  }
}

TEST(LaplaceIs, LinearGaussianMatchesTheClosedFormAndTmcmc) {
  const LinearGaussian g;
  const FunctionLikelihood like = g.likelihood();
  LaplaceIsOptions o;
  o.samples = 4000;
  o.seed = 7;
  const LaplaceIsResult r =
      run_laplace_is(g.target(), like, g.box, o, omp_executor(g.box, like, 1));
  const Eigen::VectorXd m = g.mean();
  const Eigen::VectorXd sd = g.information().inverse().diagonal().cwiseSqrt();
  // The mode of the z-target is not that of theta (Jacobian), but close for a wide box.
  EXPECT_GT(r.ess, 0.5 * o.samples);
  expect_closed_form_quantiles(g, r);
  EXPECT_GT(r.log_evidence_sd, 0);
  EXPECT_LT(r.log_evidence_sd, 0.05);
  EXPECT_NEAR(r.log_evidence, g.log_evidence(), 4 * r.log_evidence_sd);

  // TMCMC on the same problem: medians and evidence agree with the closed form (TMCMC draws
  // are correlated: 0.15 sd on the medians, its own error estimate on the evidence) and so
  // with the importance sampler.
  TmcmcOptions t;
  t.samples = 2000;
  t.seed = 7;
  const TmcmcResult tr = run_tmcmc(like, g.box, t, omp_executor(g.box, like, 1));
  ASSERT_EQ(tr.status, TmcmcStatus::converged);
  for (int k = 0; k < 2; ++k) {
    const Eigen::VectorXd x = tr.samples.col(k);
    const Eigen::VectorXd w = Eigen::VectorXd::Constant(x.size(), 1.0 / x.size());
    EXPECT_NEAR(weighted_quantile(x, w, 0.5), m(k), 0.15 * sd(k)) << k;
    EXPECT_NEAR(weighted_quantile(x, w, 0.5), weighted_quantile(r.draws.col(k), r.weights, 0.5),
                0.15 * sd(k) + 4 * 1.2533 * sd(k) / std::sqrt(r.ess))
        << k;
  }
  EXPECT_NEAR(tr.log_evidence, g.log_evidence(), 4 * tr.log_evidence_sd + 0.02);
  EXPECT_NEAR(tr.log_evidence, r.log_evidence,
              4 * std::hypot(tr.log_evidence_sd, r.log_evidence_sd) + 0.02);
}

/// Adaptive rounds (LaplaceIsOptions::rounds) on the linear-Gaussian target: the weighted
/// posterior and the evidence still match the closed form (the mixture weights are unbiased).
TEST(LaplaceIs, AdaptiveRoundsMatchTheLinearGaussianClosedForm) {
  const LinearGaussian g;
  const FunctionLikelihood like = g.likelihood();
  LaplaceIsOptions o;
  o.samples = 4000;
  o.rounds = 4;
  o.seed = 11;
  const LaplaceIsResult r =
      run_laplace_is(g.target(), like, g.box, o, omp_executor(g.box, like, 1));
  ASSERT_EQ(r.round_ess.size(), 3u);
  EXPECT_GT(r.ess, 0.5 * o.samples);
  expect_closed_form_quantiles(g, r);
  EXPECT_NEAR(r.log_evidence, g.log_evidence(), 4 * r.log_evidence_sd);
}

/// A curved ridge ("banana"): log L = -1/2 (t1 / 1)^2 - 1/2 ((t2 - t1^2) / 0.3)^2 in the box
/// [-4, 4] x [-3, 14]. The Laplace Gaussian at the mode is straight and too narrow along the
/// ridge; the adaptive rounds must raise the effective sample size and keep the evidence and
/// the quantiles of t2 on their values by quadrature (a 1,200 x 1,200 midpoint grid, which
/// resolves the 0.3-wide ridge with 12 points across it and more).
TEST(LaplaceIs, AdaptiveRoundsFollowACurvedRidge) {
  const PriorBox box{{-4.0, -3.0}, {4.0, 14.0}};
  const double s2 = 0.3;
  const auto log_l = [&](double t1, double t2) {
    return -0.5 * t1 * t1 - 0.5 * std::pow((t2 - t1 * t1) / s2, 2);
  };
  const GradientTarget target = [&](const Eigen::VectorXd& t, const WarmState&) {
    GradientPoint p;
    p.ok = true;
    p.log_likelihood = log_l(t(0), t(1));
    const Eigen::Vector2d res{t(0), (t(1) - t(0) * t(0)) / s2};
    Eigen::Matrix2d J;
    J << 1.0, 0.0, -2.0 * t(0) / s2, 1.0 / s2;  // d res / d theta
    p.gradient = -J.transpose() * res;
    p.information = J.transpose() * J;
    return p;
  };
  const FunctionLikelihood like(2, [&](std::span<const double> t) { return log_l(t[0], t[1]); });
  // Quadrature: evidence (1/V) int L, and the CDF of t2.
  const int n = 1200;
  const double h1 = 8.0 / n, h2 = 17.0 / n;
  std::vector<double> marginal2(n, 0.0);
  double total = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double l = std::exp(log_l(-4.0 + (i + 0.5) * h1, -3.0 + (j + 0.5) * h2)) * h1 * h2;
      marginal2[size_t(j)] += l;
      total += l;
    }
  const double log_z = std::log(total) - box.log_volume();
  const auto quantile2 = [&](double q) {
    double c = 0;
    for (int j = 0; j < n; ++j) {
      if (c + marginal2[size_t(j)] >= q * total)
        return -3.0 + (j + (q * total - c) / marginal2[size_t(j)]) * h2;
      c += marginal2[size_t(j)];
    }
    return 14.0;
  };
  LaplaceIsOptions o;
  o.samples = 3000;
  o.seed = 9;
  const LaplaceIsResult one = run_laplace_is(target, like, box, o, omp_executor(box, like, 1));
  o.rounds = 5;
  const LaplaceIsResult r = run_laplace_is(target, like, box, o, omp_executor(box, like, 1));
  EXPECT_GT(r.ess, 1.5 * one.ess) << "one round: " << one.ess;
  EXPECT_NEAR(r.log_evidence, log_z, 4 * r.log_evidence_sd + 1e-3);
  // Quantile standard errors from the t2 marginal's density at the quantile (finite
  // differences of the quadrature CDF).
  for (double q : {0.05, 0.5, 0.95}) {
    const double x = quantile2(q);
    const double density = 0.02 / (quantile2(q + 0.01) - quantile2(q - 0.01));
    const double se = std::sqrt(q * (1 - q)) / (density * std::sqrt(r.ess));
    EXPECT_NEAR(weighted_quantile(r.draws.col(1), r.weights, q), x, 4 * se) << q;
  }
}

/// The weighted draws of a target flat in the box are uniform in it (the log-Jacobian of the
/// logit map in the weights): Kolmogorov-Smirnov distance of the weighted empirical CDF of
/// each coordinate's position in the box against the uniform CDF, below the 0.1 % critical
/// value 1.95 / sqrt(ESS); and the evidence is 1 (the prior is normalised).
TEST(LaplaceIs, FlatTargetGivesUniformSamplesInTheBox) {
  const PriorBox box{{1.0, 0.0}, {3.0, 10.0}};
  const GradientTarget flat = [](const Eigen::VectorXd&, const WarmState&) {
    GradientPoint p;
    p.ok = true;
    p.log_likelihood = 0;
    p.gradient = Eigen::VectorXd::Zero(2);
    p.information = Eigen::MatrixXd::Zero(2, 2);
    return p;
  };
  const FunctionLikelihood like(2, [](std::span<const double>) { return 0.0; });
  LaplaceIsOptions o;
  o.samples = 4000;
  o.seed = 3;
  const LaplaceIsResult r = run_laplace_is(flat, like, box, o, omp_executor(box, like, 1));
  EXPECT_NEAR(r.mode_z.norm(), 0.0, 1e-12);
  for (int k = 0; k < 2; ++k) {
    const int n = static_cast<int>(r.draws.rows());
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return r.draws(a, k) < r.draws(b, k); });
    double cdf = 0, ks = 0;
    for (int i : order) {
      const double u = (r.draws(i, k) - box.lower[k]) / (box.upper[k] - box.lower[k]);
      ks = std::max(ks, std::abs(cdf - u));
      cdf += r.weights(i);
      ks = std::max(ks, std::abs(cdf - u));
    }
    EXPECT_LT(ks, 1.95 / std::sqrt(r.ess)) << k;
  }
  EXPECT_NEAR(r.log_evidence, 0.0, 4 * r.log_evidence_sd);
}

/// The mode search ends where the gradient of the logit-space target
/// log L(theta(z)) + log prior(z) vanishes, checked by central differences of that target
/// (independent of the sampler's chain rule and Jacobian gradient).
TEST(LaplaceIs, ModeIsAStationaryPointOfTheLogitTarget) {
  const LinearGaussian g;
  const FunctionLikelihood like = g.likelihood();
  LaplaceIsOptions o;
  o.samples = 20;
  const LaplaceIsResult r =
      run_laplace_is(g.target(), like, g.box, o, omp_executor(g.box, like, 1));
  const auto log_post = [&](const Eigen::VectorXd& z) {
    return g.log_l(logit_to_box(g.box, z)) + logit_log_prior(z);
  };
  const double h = 1e-5;
  for (int k = 0; k < 2; ++k) {
    Eigen::VectorXd zp = r.mode_z, zm = r.mode_z;
    zp(k) += h;
    zm(k) -= h;
    EXPECT_NEAR((log_post(zp) - log_post(zm)) / (2 * h), 0.0, 1e-4) << k;
  }
  EXPECT_LT(r.newton_steps, o.max_newton_steps);
}

TEST(LaplaceIs, DrawsDependOnTheSeedOnlyNotOnTheThreadCount) {
  const LinearGaussian g;
  const FunctionLikelihood like = g.likelihood();
  LaplaceIsOptions o;
  o.samples = 500;
  const LaplaceIsResult a =
      run_laplace_is(g.target(), like, g.box, o, omp_executor(g.box, like, 1));
  const LaplaceIsResult b =
      run_laplace_is(g.target(), like, g.box, o, omp_executor(g.box, like, 2));
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.log_evidence, b.log_evidence);
  o.seed = 2;
  const LaplaceIsResult c =
      run_laplace_is(g.target(), like, g.box, o, omp_executor(g.box, like, 1));
  EXPECT_NE(a.samples, c.samples);
}

TEST(LaplaceIs, StudentTDensityMatchesTheUnivariateForm) {
  // d = 1, nu = 5, scale 2: the textbook density at x = 1.3 around m = 0.4.
  const Eigen::VectorXd x{{1.3}}, m{{0.4}};
  const Eigen::MatrixXd chol{{2.0}};
  const double nu = 5, t = (1.3 - 0.4) / 2.0;
  const double expect = std::lgamma(3.0) - std::lgamma(2.5) - 0.5 * std::log(nu * M_PI) -
                        std::log(2.0) - 3.0 * std::log1p(t * t / nu);
  EXPECT_NEAR(student_t_log_density(x, m, chol, nu), expect, 1e-13);
}

TEST(LaplaceIs, BadOptionsAreNamed) {
  LaplaceIsOptions o;
  o.samples = 3;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = {};
  o.nu = 2;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = {};
  o.rounds = 0;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.rounds = o.samples + 1;
  EXPECT_THROW(o.validate(), std::invalid_argument);
}

// ---- continuation (LaplaceIsContinuation) ---------------------------------------------------

/// The linear-Gaussian target with a warm state that changes the result, as the forward
/// model's equilibria change the last digits of a solve: log L gets 1e-6 x (the warm state's
/// first value) and each point hands out its theta as its state.
struct WarmLinearGaussian final : Likelihood {
  LinearGaussian g;
  int dimension() const override { return 2; }
  static double warm_term(const WarmState& w) { return w.empty() ? 0.0 : 1e-6 * w[0]; }
  LikelihoodValue evaluate(std::span<const double> t, const WarmState& warm,
                           WarmState* out) const override {
    if (out) *out = {t[0], t[1]};
    return {g.log_l(Eigen::Vector2d(t[0], t[1])) + warm_term(warm), false, false, false};
  }
  GradientTarget target() const {
    return [this](const Eigen::VectorXd& t, const WarmState& warm) {
      GradientPoint p = g.target()(t, warm);
      p.log_likelihood += warm_term(warm);
      p.state = {t(0), t(1)};
      return p;
    };
  }
};

void expect_same_result(const LaplaceIsResult& a, const LaplaceIsResult& b) {
  EXPECT_EQ(a.mode_z, b.mode_z);
  EXPECT_EQ(a.covariance_z, b.covariance_z);
  EXPECT_EQ(a.newton_steps, b.newton_steps);
  EXPECT_EQ(a.gradient_evaluations, b.gradient_evaluations);
  EXPECT_EQ(a.draws, b.draws);
  EXPECT_EQ(a.draw_log_likelihood, b.draw_log_likelihood);
  EXPECT_EQ(a.draw_states, b.draw_states);
  EXPECT_EQ(a.weights, b.weights);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.log_evidence, b.log_evidence);
  EXPECT_EQ(a.log_evidence_sd, b.log_evidence_sd);
  EXPECT_EQ(a.counts.runs, b.counts.runs);
}

TEST(LaplaceIs, ContinuedFromAnyHandedOutStateTheRunEqualsTheStraightRunExactly) {
  const WarmLinearGaussian w;
  for (int rounds : {1, 3}) {
    SCOPED_TRACE("rounds " + std::to_string(rounds));
    LaplaceIsOptions o;
    o.samples = 60;
    o.seed = 5;
    o.rounds = rounds;
    std::vector<LaplaceIsState> states;
    LaplaceIsContinuation record;
    record.block = 7;
    record.checkpoint = [&](const LaplaceIsState& s) { states.push_back(s); };
    const LaplaceIsResult straight =
        run_laplace_is(w.target(), w, w.g.box, o, omp_executor(w.g.box, w, 1), record);
    // The same without checkpoints (one batch of draws per round).
    expect_same_result(straight,
                       run_laplace_is(w.target(), w, w.g.box, o, omp_executor(w.g.box, w, 2)));
    // First evaluation, every Newton step, the mode, then the blocks: ceil(60 / 7) = 9 with
    // one round; with three, blocks also end at the rounds' ends (20 and 40): 11.
    ASSERT_EQ(static_cast<int>(states.size()),
              1 + straight.newton_steps + 1 + (rounds == 1 ? 9 : 11));
    ASSERT_GE(straight.newton_steps, 2);
    EXPECT_FALSE(states.front().mode_found);
    EXPECT_TRUE(states.back().mode_found);
    EXPECT_EQ(states.back().draws_done, o.samples);
    for (size_t k = 0; k < states.size(); ++k) {
      SCOPED_TRACE("state " + std::to_string(k));
      LaplaceIsContinuation c;
      c.resume = &states[k];
      c.block = 13;  // other blocks, other threads
      c.checkpoint = [](const LaplaceIsState&) {};
      expect_same_result(straight,
                         run_laplace_is(w.target(), w, w.g.box, o, omp_executor(w.g.box, w, 2), c));
    }
  }
}

TEST(LaplaceIs, CancelStopsBetweenEvaluationsAndTheLastStateContinues) {
  const WarmLinearGaussian w;
  LaplaceIsOptions o;
  o.samples = 40;
  const LaplaceIsResult straight =
      run_laplace_is(w.target(), w, w.g.box, o, omp_executor(w.g.box, w, 1));
  // Polled before every gradient evaluation and every block: stop during the mode search, and
  // after two blocks of draws.
  const int in_draws = static_cast<int>(straight.gradient_evaluations) + 2;
  for (int polls : {2, in_draws}) {
    SCOPED_TRACE(polls);
    int calls = 0;
    o.cancel = [&] { return ++calls > polls; };
    std::optional<LaplaceIsState> last;
    LaplaceIsContinuation c;
    c.block = 10;
    c.checkpoint = [&](const LaplaceIsState& s) { last = s; };
    EXPECT_THROW(run_laplace_is(w.target(), w, w.g.box, o, omp_executor(w.g.box, w, 1), c),
                 Cancelled);
    ASSERT_TRUE(last.has_value());
    o.cancel = {};
    LaplaceIsContinuation r;
    r.resume = &*last;
    expect_same_result(straight,
                       run_laplace_is(w.target(), w, w.g.box, o, omp_executor(w.g.box, w, 2), r));
  }
}

}  // namespace
}  // namespace rbc
