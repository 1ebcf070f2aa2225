// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Transitional Markov chain Monte Carlo (TMCMC; J. Ching and Y.-C. Chen, "Transitional
// Markov chain Monte Carlo method for Bayesian model updating, model class selection, and
// model averaging", J. Eng. Mech. 133 (2007) 816-832), written small here because no
// well-kept C++ TMCMC library is packaged in Debian (`apt-cache search tmcmc`,
// "transitional markov", "sequential monte carlo" find nothing; the MCMC packages are
// BEAST (phylogenetics) and R modules).
//
// The sampler moves a population of `samples` points from the prior (beta_0 = 0) to the
// posterior (beta_m = 1) through the tempered densities  p_j(theta) ~ prior(theta) L(theta)^beta_j.
// Each stage j -> j+1:
//  1. beta_{j+1} in (beta_j, 1] by bisection so that the coefficient of variation (sd/mean)
//     of the weights w_i = L(theta_i)^(beta_{j+1} - beta_j) equals target_cov (1), or
//     beta_{j+1} = 1 if that keeps the coefficient of variation at or below target_cov;
//  2. the evidence factor of the stage: the mean of the weights (per island, below);
//  3. resampling: the population is split into `islands` fixed blocks of indices; each
//     block draws its parents multinomially from its own samples with probabilities
//     w_i / sum_block w (each block is an independent TMCMC population sharing the exponent
//     schedule and the proposal covariance);
//  4. each resampled point starts a Metropolis chain of `chain_length` steps targeting
//     p_{j+1}, with the Gaussian proposal theta' = theta + N(0, proposal_scale^2 Sigma),
//     Sigma the weighted sample covariance of the stage (all blocks, each of mass 1/B); the
//     chain's last state is the new sample. Proposals outside the prior box are rejected
//     without a likelihood call.
// Evidence and its error: each block b estimates Z_b = prod_j mean_{i in b} w_i (the product
// of the stage means estimates the evidence p(data) = integral prior L); the result is
// log Z = log mean_b Z_b and its error the blocks' scatter, sd_b(log Z_b)/sqrt(B). The
// blocks are independent up to the shared schedule, so this error is honest; the textbook
// delta-method error sqrt(sum_j cov_j^2/N) assumes independent samples within a stage and
// was measured 3-4x too small against a closed form (tests/calibrate/test_tmcmc.cpp). With
// islands = 1 the delta method is what is reported.
// Determinism: each random draw comes from a std::mt19937_64 seeded by a std::seed_seq of
// (seed, stage, index, purpose): stage 0 sample i's prior draw, stage j's resampling, and
// stage j chain k's proposals each have their own stream. A chain's result depends only on
// its inputs (parent point, parent warm state, stage setup, stream), so the posterior
// samples depend on the seed only, not on how chains are spread over threads or ranks.
//
// Parallelism: the sampler hands each stage's independent chains to an Executor, which
// runs run_chain() on every task (in any order, anywhere): omp_executor() uses OpenMP
// threads; calibrate/mpi_executor.hpp adds a master-worker pool over MPI ranks.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "core/progress.hpp"

namespace rbc {

/// Opaque state a likelihood may carry from a parent sample to its children (e.g. the
/// forward model's equilibria, used as warm starts). Empty = none (cold start).
using WarmState = std::vector<double>;

/// Counts of forward-model work behind likelihood evaluations.
struct ForwardCounts {
  long long runs = 0;     ///< likelihood evaluations (forward sweeps)
  long long retried = 0;  ///< evaluations that needed a retry with smaller steps
  long long failed = 0;   ///< evaluations that failed even after retrying (zero likelihood)
  /// evaluations whose symmetric equilibria were saddles, solved again in full
  long long symmetry_broken = 0;
  ForwardCounts& operator+=(const ForwardCounts& o) {
    runs += o.runs;
    retried += o.retried;
    failed += o.failed;
    symmetry_broken += o.symmetry_broken;
    return *this;
  }
};

/// One likelihood evaluation.
struct LikelihoodValue {
  double log_likelihood = 0;  ///< log L(theta); -infinity for a failed forward run
  bool retried = false, failed = false, symmetry_broken = false;
};

/// A log-likelihood. evaluate() must be safe to call concurrently from several threads and
/// depend only on (theta, warm): it must not keep results of earlier calls.
class Likelihood {
 public:
  virtual ~Likelihood() = default;
  virtual int dimension() const = 0;
  /// log L at theta (dimension() values). warm: the parent's state (may be empty); state_out
  /// (may be nullptr): receives this point's state for its children.
  virtual LikelihoodValue evaluate(std::span<const double> theta, const WarmState& warm,
                                   WarmState* state_out) const = 0;
};

/// A stateless log-likelihood from a function (analytic test densities).
class FunctionLikelihood final : public Likelihood {
 public:
  FunctionLikelihood(int dim, std::function<double(std::span<const double>)> f)
      : dim_(dim), f_(std::move(f)) {}
  int dimension() const override { return dim_; }
  LikelihoodValue evaluate(std::span<const double> theta, const WarmState&,
                           WarmState*) const override {
    return {f_(theta), false, false};
  }

 private:
  int dim_;
  std::function<double(std::span<const double>)> f_;
};

/// Uniform prior on a box lower < theta < upper (per coordinate).
struct PriorBox {
  std::vector<double> lower, upper;
  int dimension() const { return static_cast<int>(lower.size()); }
  bool contains(std::span<const double> theta) const;
  double log_volume() const;
  /// Throws std::invalid_argument naming the coordinate unless lower < upper, both finite.
  void validate(const std::vector<std::string>& names = {}) const;
};

/// Sampler settings. Defaults are those of `rbc infer` (calibrate/infer.hpp).
struct TmcmcOptions {
  int samples = 1000;           ///< population size per stage
  double target_cov = 1.0;      ///< target coefficient of variation of the stage weights
  double proposal_scale = 0.2;  ///< beta: proposal covariance = beta^2 x weighted sample cov
  int chain_length = 3;         ///< Metropolis steps per resampled point and stage
  int islands = 4;       ///< independent resampling blocks (evidence error), >= 5 samples each
  int max_stages = 200;  ///< safety cap on the number of tempering stages
  std::uint64_t seed = 1;
  /// Stop with status failed_runs once more than this fraction of the forward runs failed
  /// (checked after every stage).
  double max_failure_fraction = 0.01;
  CancelCheck cancel;  ///< polled between stages
  void validate() const;
};

/// The random stream of (seed, stage, index, purpose).
std::uint64_t stream_seed(std::uint64_t seed, int stage, int index, int purpose);

/// Uniform (0, 1) and Box-Muller normal draws from a mt19937_64 seeded with stream_seed(): the
/// samplers' random streams (TMCMC, laplace-is). Written out rather than taken from <random>'s
/// distributions, whose outputs differ between standard libraries, so that a posterior is the
/// same on every platform.
class NormalStream {
 public:
  explicit NormalStream(std::uint64_t s) : gen_(s) {}
  double uniform() {  // in (0, 1)
    return (static_cast<double>(gen_() >> 11) + 0.5) * 0x1.0p-53;
  }
  double normal() {
    if (have_) {
      have_ = false;
      return spare_;
    }
    const double r = std::sqrt(-2.0 * std::log(uniform()));
    const double t = 2.0 * M_PI * uniform();
    spare_ = r * std::sin(t);
    have_ = true;
    return r * std::cos(t);
  }

 private:
  std::mt19937_64 gen_;
  double spare_ = 0;
  bool have_ = false;
};

/// What a chain needs to know about its stage.
struct StageSetup {
  int stage = 0;
  double beta = 0;                ///< tempering exponent of the stage's target
  Eigen::MatrixXd proposal_chol;  ///< lower Cholesky factor of the proposal covariance
  int chain_length = 0;           ///< 0: stage 0, evaluate the task's theta only
  std::uint64_t seed = 1;
};

/// One independent unit of work: a chain from a parent point (or, at stage 0, one
/// evaluation at a prior draw). Inputs: index, theta, log_likelihood, state (the
/// parent's). Run in place: on return they hold the chain's last state.
struct ChainTask {
  int index = 0;
  std::vector<double> theta;
  double log_likelihood = 0;
  WarmState state;
  int proposed = 0, accepted = 0;  ///< Metropolis proposals / acceptances (inside the box)
  ForwardCounts counts;
};

/// Runs one task: stage 0 evaluates at theta; otherwise chain_length Metropolis steps.
void run_chain(const StageSetup& setup, const PriorBox& prior, const Likelihood& likelihood,
               ChainTask& task);

/// Runs run_chain on every task (tasks are independent).
using Executor = std::function<void(const StageSetup&, std::vector<ChainTask>&)>;

/// OpenMP executor: one task per thread, schedule(dynamic); inner parallel regions of the
/// likelihood run at one thread. threads <= 0: OpenMP's default. With `cancel`, polled before
/// each task: once it is true no further task starts and the executor throws rbc::Cancelled
/// when the running ones are done (the stage is abandoned; the previous stage's state stands).
Executor omp_executor(const PriorBox& prior, const Likelihood& likelihood, int threads = 0,
                      CancelCheck cancel = {});

/// Per-stage diagnostics.
struct StageInfo {
  int stage = 0;
  double beta = 0;
  double cov = 0;              ///< coefficient of variation of the weights that led here
  double log_mean_weight = 0;  ///< this stage's evidence increment
  double acceptance = 0;       ///< Metropolis acceptance rate of the stage's chains
  double unique_fraction = 0;  ///< distinct parents after resampling / samples
  long long forward_runs = 0;  ///< cumulative
  double elapsed_s = 0;        ///< wall time since the start
};

/// How a posterior run ended: converged; TMCMC's tempering did not reach beta = 1 within its
/// stages (max_stages); more than 1 % of the forward runs failed (failed_runs); the importance
/// weights of laplace-is left fewer effective samples than InferOptions::min_effective_samples
/// (calibrate/infer.hpp; low_ess).
enum class TmcmcStatus { converged, max_stages, failed_runs, low_ess };
std::string to_string(TmcmcStatus s);

struct TmcmcResult {
  TmcmcStatus status = TmcmcStatus::converged;
  Eigen::MatrixXd samples;         ///< samples x dim: equally weighted posterior draws
  Eigen::VectorXd log_likelihood;  ///< per sample
  std::vector<WarmState> states;   ///< per sample (the likelihood's warm states)
  double log_evidence = 0;         ///< log p(data) = sum_j log mean w_j (+ nothing else)
  double log_evidence_sd = 0;      ///< delta-method estimate (see the header)
  std::vector<StageInfo> stages;
  ForwardCounts counts;
  double wall_s = 0;
};

/// Called after each stage (progress, checks). May be empty.
using StageCallback = std::function<void(const StageInfo&)>;

/// A population sampler's state after a completed stage: everything the next stage needs, in
/// a layout that names no sampler internals beyond "population + schedule + accumulators"
/// (calibrate/stage_checkpoint.hpp stores it in a file). TMCMC's next stage depends on this
/// state and the options only (Determinism above), so a run continued from it ends with the
/// same samples, evidence and stage log as a run that never stopped, bit for bit.
struct SamplerState {
  std::string sampler = "tmcmc";   ///< which sampler wrote it
  int stage = 0;                   ///< stages completed after the prior draws (0: prior only)
  Eigen::MatrixXd theta;           ///< population, samples x dimension
  Eigen::VectorXd log_likelihood;  ///< per sample (-infinity: failed forward run)
  std::vector<WarmState> states;   ///< per sample (the likelihood's warm states)
  std::vector<double> schedule;    ///< tempering exponents beta_0 = 0, ..., beta_stage
  /// Named running sums of the sampler. TMCMC: "log_evidence_island" (log Z_b so far, one per
  /// island) and "delta_method_variance" (sum_j cov_j^2 / N, one value).
  std::vector<std::pair<std::string, std::vector<double>>> accumulators;
  ForwardCounts counts;           ///< forward runs so far
  std::vector<StageInfo> stages;  ///< the stage log, stages 0..stage
  /// The accumulator called `name`; throws std::invalid_argument if there is none.
  const std::vector<double>& accumulator(const std::string& name) const;
};

/// How a run starts and what it hands out after every stage.
struct TmcmcContinuation {
  /// Continue from this state instead of drawing from the prior (nullptr: a new run). It must
  /// come from a run with the same likelihood, prior and options (std::invalid_argument
  /// otherwise, where the state can tell).
  const SamplerState* resume = nullptr;
  /// Called with the state after every completed stage, stage 0 included, before on_stage
  /// (e.g. to write a checkpoint). May be empty.
  std::function<void(const SamplerState&)> checkpoint;
};

/// Runs TMCMC with the executor (omp_executor(prior, likelihood) when empty).
TmcmcResult run_tmcmc(const Likelihood& likelihood, const PriorBox& prior,
                      const TmcmcOptions& options, const Executor& executor = {},
                      const StageCallback& on_stage = {});
/// The same, continuing a stored state and/or handing out the state after every stage.
TmcmcResult run_tmcmc(const Likelihood& likelihood, const PriorBox& prior,
                      const TmcmcOptions& options, const Executor& executor,
                      const StageCallback& on_stage, const TmcmcContinuation& continuation);

/// Bisection for the next exponent: the smallest db in (0, 1 - beta] with
/// cov(exp(db (l - max l))) >= target, or 1 - beta if cov stays below target. Returns beta + db.
double next_tempering_exponent(const Eigen::VectorXd& log_likelihood, double beta,
                               double target_cov);

/// Coefficient of variation (sd / mean, population sd) of exp(db * l) computed stably.
double weight_cov(const Eigen::VectorXd& log_likelihood, double db);

}  // namespace rbc
