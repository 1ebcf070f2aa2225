// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Laplace proposal with importance correction (`rbc infer --sampler laplace-is`): a second
// posterior sampler next to TMCMC (calibrate/tmcmc.hpp) that uses the likelihood's gradient
// and its Gauss-Newton information, and gives the evidence.
//
// 1. Coordinates. The prior is a uniform box a < theta < b (PriorBox). Each coordinate is
//    mapped to the real line by the logit of its position in the box,
//      z = log(u / (1 - u)),  u = (theta - a) / (b - a),  theta = a + (b - a) s(z),
//    s the logistic function. The prior in z is prod_k s(z_k) (1 - s(z_k)) (the uniform
//    density 1/V times the Jacobian (b - a) s (1 - s); the volume cancels), so the target is
//      log pi(z) = log L(theta(z)) + sum_k [log s(z_k) + log(1 - s(z_k))].
// 2. Mode. Damped Newton steps in z from the prior centre (z = 0) with the gradient
//      g_z = D g_theta + (1 - 2 s),  D = diag((b - a) s (1 - s)),
//    and the Gauss-Newton Hessian H_z = D F D + diag(2 s (1 - s)) (F the Gauss-Newton Fisher
//    information of the likelihood in theta; the second term the prior's exact curvature in z,
//    so H_z is positive definite even where the data say nothing). A step is halved (up to 10
//    times) until log pi grows; the iteration stops when the Newton decrement g' H^-1 g falls
//    below mode_tolerance or after max_newton_steps.
// 3. Proposal. A multivariate Student-t with nu = 5 degrees of freedom centred at the mode,
//    scale matrix inflation x H_z^-1 (inflation 1.5 by default). nu = 5: heavy enough tails that
//    the importance weights L prior / q stay bounded where the posterior's tails exceed the
//    Laplace Gaussian's (a Gaussian proposal gives unbounded weights there), while keeping a
//    finite variance (nu > 2) and most draws where the posterior is; the inflation covers a
//    Gauss-Newton curvature that is too large (GN drops the residuals' second derivatives).
//    Draw i uses its own stream stream_seed(seed, 0, i, purpose) (Box-Muller normals and a
//    chi-square from nu normals), so the draws do not depend on threads or ranks.
// 3b. Adaptation (LaplaceIsOptions::rounds = R > 1): adaptive multiple importance sampling
//    (Cornuet, Marin, Mira and Robert, Scand. J. Stat. 2012). The draws are split into R rounds;
//    round 0 uses the Laplace proposal q_0, and after round t the proposal q_{t+1} is the
//    Student-t whose location is the weighted mean and whose scale matrix is the weighted
//    covariance C of all draws so far, blended with q_t's scale Sigma_t as
//    lambda C + (1 - lambda) Sigma_t, lambda = min(1, ESS / (10 d)), so that a few dominant
//    draws cannot collapse it. Every draw's weight uses the deterministic mixture
//    q(z) = sum_t (n_t / S) q_t(z) (the balance heuristic), in the refits and in the final
//    weights. The Laplace Gaussian cannot follow a curved ridge; the refit covers the ridge's
//    extent, and the mixture keeps the weights of the Laplace round's draws bounded.
// 4. Importance weights w_i = prior(z_i) L(theta_i) / q(z_i) (log space). The evidence is
//    Z = mean w (the prior is normalised), its error by the delta method,
//    sd(log Z) = sd(w) / (sqrt(S) mean w); the effective sample size is (sum w)^2 / sum w^2.
//    The S likelihood evaluations go through the same Executor as TMCMC's stage 0 (run_chain
//    with chain_length 0), warm-started from the mode's state. Equally weighted samples are
//    drawn by systematic resampling (one uniform from the seed), so outputs written for TMCMC
//    samples work unchanged; the summaries use the weights themselves (weighted quantiles).
// 5. Continuation. The run's state (LaplaceIsState) is handed out after the first gradient
//    evaluation, after every Newton step, when the mode is found and after every block of
//    importance draws (LaplaceIsContinuation; calibrate/laplace_is_checkpoint.hpp stores it).
//    A run continued from it gives the straight run's result bit for bit: a Newton step
//    depends on the current point's evaluation only, and every draw is evaluated from the
//    mode's warm state with its own stream, whatever the block it falls in. options.cancel is
//    polled before every gradient evaluation and before every block (rbc::Cancelled).
//
// Measured at the default calibration (Suresh 2005 table, continuum:2:2000, persistence, lmax,
// sigma-scale; 2 threads on a shared 2-core machine): 8 Newton steps, 23 gradient evaluations,
// then 1,000 importance samples: 1,023 forward runs in 76 s against TMCMC's 6,064 runs;
// ESS 383 (seed 1) and 156 (seed 2), log evidence -36.15 +- 0.04 and -36.18 +- 0.07 against
// TMCMC's -36.00 +- 0.11; medians and 90 % intervals of p, Lmax, sigma-scale, mu and K within
// a few per cent of TMCMC's. The p-Lmax ridge of those data is curved in logit coordinates,
// so the weights are uneven (ESS 15-40 % of the draws); 300 samples give ESS 121, log evidence
// -36.23 +- 0.07, in 23 s.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "calibrate/tmcmc.hpp"

namespace rbc {

/// log L, its gradient and Gauss-Newton information at a point (natural coordinates).
struct GradientPoint {
  bool ok = false;  ///< false: the evaluation failed (log L = -infinity)
  double log_likelihood = 0;
  Eigen::VectorXd gradient;     ///< d log L / d theta
  Eigen::MatrixXd information;  ///< Gauss-Newton Fisher information (positive semi-definite)
  WarmState state;              ///< the likelihood's warm state there (may be empty)
};
/// The likelihood with derivatives, for the mode search. warm: a state to start from.
using GradientTarget =
    std::function<GradientPoint(const Eigen::VectorXd& theta, const WarmState& warm)>;

struct LaplaceIsOptions {
  int samples = 1000;      ///< importance samples S
  double nu = 5;           ///< Student-t degrees of freedom (> 2)
  double inflation = 1.5;  ///< factor on the Laplace covariance
  /// Adaptation rounds R (1 to samples): the S draws are split into R rounds of S/R; round 0
  /// draws from the Laplace proposal, each later round from a Student-t refit to the weighted
  /// draws before it, and every draw is weighted against the mixture of all R proposals (see
  /// the file comment, 3b). 1: the Laplace proposal alone.
  int rounds = 1;
  int max_newton_steps = 30;
  double mode_tolerance = 1e-8;  ///< on the Newton decrement g' H^-1 g
  std::uint64_t seed = 1;
  CancelCheck cancel;     ///< polled before every gradient evaluation and block of draws
  void validate() const;  ///< throws std::invalid_argument naming the value
};

/// Where a run is: the mode search's current point, or the mode and the importance draws
/// evaluated so far (the first draws_done, in draw order). The draws themselves follow from
/// the mode, its Laplace covariance and the seed, so they are not part of the state.
struct LaplaceIsState {
  bool mode_found = false;  ///< false: the mode search continues after newton_steps steps
  int newton_steps = 0;
  long long gradient_evaluations = 0;
  Eigen::VectorXd z;    ///< the search's current point, logit coordinates (the mode once found)
  GradientPoint point;  ///< the target at z: log L, gradient, information, warm state
  int draws_done = 0;   ///< importance draws evaluated (mode_found only)
  Eigen::VectorXd draw_log_likelihood;  ///< of those draws
  std::vector<WarmState> draw_states;   ///< of those draws
  ForwardCounts counts;                 ///< of those draws' forward runs
};

/// How a run starts and what it hands out.
struct LaplaceIsContinuation {
  /// Continue from this state (nullptr: a new run). It must come from a run with the same
  /// target, prior and options.
  const LaplaceIsState* resume = nullptr;
  /// Called with the state after the first gradient evaluation, every Newton step, the mode
  /// search and every block of importance draws. Empty: none, and the draws go to the
  /// executor in one batch.
  std::function<void(const LaplaceIsState&)> checkpoint;
  /// Importance draws per block; 0: laplace_is_block(samples).
  int block = 0;
};

/// The default block of importance draws between checkpoints: samples / 20 rounded up, at
/// least 10 (at most 20 checkpoint writes, each holding every evaluated draw's warm state).
int laplace_is_block(int samples);

struct LaplaceIsResult {
  Eigen::VectorXd mode_theta, mode_z;  ///< posterior mode (natural and logit coordinates)
  Eigen::MatrixXd covariance_z;        ///< Laplace covariance H_z^-1 (before inflation)
  int newton_steps = 0;
  long long gradient_evaluations = 0;  ///< calls of the GradientTarget
  Eigen::MatrixXd draws;               ///< S x d proposal draws (natural units)
  Eigen::VectorXd draw_log_likelihood;
  std::vector<WarmState> draw_states;
  Eigen::VectorXd weights;  ///< normalised importance weights (sum 1)
  Eigen::MatrixXd samples;  ///< S x d, equally weighted (systematic resampling)
  Eigen::VectorXd log_likelihood;
  std::vector<WarmState> states;
  double log_evidence = 0, log_evidence_sd = 0, ess = 0;
  /// ESS of the draws of rounds 0..t against the mixture of their proposals, after each round
  /// but the last (empty with one round).
  std::vector<double> round_ess;
  ForwardCounts counts;  ///< of the S importance evaluations
  double wall_s = 0;
};

/// The logit map of the box and its inverse, and the log prior density in z.
Eigen::VectorXd box_to_logit(const PriorBox& box, const Eigen::VectorXd& theta);
Eigen::VectorXd logit_to_box(const PriorBox& box, const Eigen::VectorXd& z);
double logit_log_prior(const Eigen::VectorXd& z);

/// log density of the multivariate Student-t (location m, lower Cholesky factor L of the scale
/// matrix, nu degrees of freedom) at x.
double student_t_log_density(const Eigen::VectorXd& x, const Eigen::VectorXd& m,
                             const Eigen::MatrixXd& chol, double nu);

/// Runs the sampler: mode search with `target`, S evaluations of `likelihood` through
/// `executor` (omp_executor(prior, likelihood) when empty). Throws std::runtime_error when the
/// mode search fails (the target fails at the prior centre) or every weight is zero.
LaplaceIsResult run_laplace_is(const GradientTarget& target, const Likelihood& likelihood,
                               const PriorBox& prior, const LaplaceIsOptions& options,
                               const Executor& executor = {});
/// The same, continuing a stored state and/or handing out the state as it goes.
LaplaceIsResult run_laplace_is(const GradientTarget& target, const Likelihood& likelihood,
                               const PriorBox& prior, const LaplaceIsOptions& options,
                               const Executor& executor, const LaplaceIsContinuation& continuation);

/// Weighted quantile (weights summing to 1; linear interpolation of the weighted CDF at the
/// midpoints of the sorted samples' masses).
double weighted_quantile(const Eigen::VectorXd& x, const Eigen::VectorXd& w, double q);

}  // namespace rbc
