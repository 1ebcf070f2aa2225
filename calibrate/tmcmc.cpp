// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/tmcmc.hpp"

#include <omp.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace rbc {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
/// Purposes of the random streams.
enum StreamPurpose : int { kPriorDraw = 1, kResample = 2, kChain = 3 };

std::string coordinate_name(const std::vector<std::string>& names, int k) {
  return k < static_cast<int>(names.size()) ? names[k] : "coordinate " + std::to_string(k);
}
}  // namespace

bool PriorBox::contains(std::span<const double> theta) const {
  for (size_t k = 0; k < lower.size(); ++k)
    if (!(theta[k] > lower[k] && theta[k] < upper[k])) return false;
  return true;
}

double PriorBox::log_volume() const {
  double v = 0;
  for (size_t k = 0; k < lower.size(); ++k) v += std::log(upper[k] - lower[k]);
  return v;
}

void PriorBox::validate(const std::vector<std::string>& names) const {
  if (lower.size() != upper.size() || lower.empty())
    throw std::invalid_argument("prior box needs as many lower as upper bounds, at least one");
  for (size_t k = 0; k < lower.size(); ++k) {
    const int i = static_cast<int>(k);
    if (!std::isfinite(lower[k]) || !std::isfinite(upper[k]) || !(lower[k] < upper[k]))
      throw std::invalid_argument("prior of " + coordinate_name(names, i) +
                                  " must be a finite interval lower < upper, got " +
                                  std::to_string(lower[k]) + ":" + std::to_string(upper[k]));
  }
}

void TmcmcOptions::validate() const {
  if (samples < 10)
    throw std::invalid_argument("samples per stage must be >= 10, got " + std::to_string(samples));
  if (!(target_cov > 0) || !std::isfinite(target_cov))
    throw std::invalid_argument("target coefficient of variation must be finite and > 0, got " +
                                std::to_string(target_cov));
  if (!(proposal_scale > 0) || !std::isfinite(proposal_scale))
    throw std::invalid_argument("proposal scale must be finite and > 0, got " +
                                std::to_string(proposal_scale));
  if (chain_length < 1)
    throw std::invalid_argument("chain length must be >= 1, got " + std::to_string(chain_length));
  if (islands < 1 || samples < 5 * islands)
    throw std::invalid_argument("islands must be >= 1 with >= 5 samples each, got " +
                                std::to_string(islands) + " islands for " +
                                std::to_string(samples) + " samples");
  if (max_stages < 1)
    throw std::invalid_argument("max stages must be >= 1, got " + std::to_string(max_stages));
  if (!(max_failure_fraction >= 0 && max_failure_fraction <= 1))
    throw std::invalid_argument("max failure fraction must be in [0, 1], got " +
                                std::to_string(max_failure_fraction));
}

std::string to_string(TmcmcStatus s) {
  switch (s) {
    case TmcmcStatus::converged:
      return "converged";
    case TmcmcStatus::max_stages:
      return "max_stages";
    case TmcmcStatus::failed_runs:
      return "failed_runs";
    case TmcmcStatus::low_ess:
      return "low_ess";
  }
  return "unknown";
}

std::uint64_t stream_seed(std::uint64_t seed, int stage, int index, int purpose) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed & 0xffffffffu),
                    static_cast<std::uint32_t>(seed >> 32), static_cast<std::uint32_t>(stage),
                    static_cast<std::uint32_t>(index), static_cast<std::uint32_t>(purpose)};
  std::array<std::uint32_t, 2> out{};
  seq.generate(out.begin(), out.end());
  return (static_cast<std::uint64_t>(out[0]) << 32) | out[1];
}

void run_chain(const StageSetup& setup, const PriorBox& prior, const Likelihood& likelihood,
               ChainTask& task) {
  if (setup.chain_length == 0) {
    WarmState out;
    const LikelihoodValue v = likelihood.evaluate(task.theta, task.state, &out);
    task.log_likelihood = v.failed ? -kInf : v.log_likelihood;
    task.state = std::move(out);
    ++task.counts.runs;
    task.counts.retried += v.retried;
    task.counts.failed += v.failed;
    task.counts.symmetry_broken += v.symmetry_broken;
    return;
  }
  NormalStream rng(stream_seed(setup.seed, setup.stage, task.index, kChain));
  const int d = static_cast<int>(task.theta.size());
  Eigen::VectorXd z(d);
  std::vector<double> proposal(d);
  for (int step = 0; step < setup.chain_length; ++step) {
    for (int k = 0; k < d; ++k) z(k) = rng.normal();
    const double u = rng.uniform();  // drawn every step: the stream does not depend on outcomes
    const Eigen::VectorXd dz = setup.proposal_chol * z;
    for (int k = 0; k < d; ++k) proposal[k] = task.theta[k] + dz(k);
    if (!prior.contains(proposal)) continue;
    ++task.proposed;
    WarmState out;
    const LikelihoodValue v = likelihood.evaluate(proposal, task.state, &out);
    ++task.counts.runs;
    task.counts.retried += v.retried;
    task.counts.failed += v.failed;
    task.counts.symmetry_broken += v.symmetry_broken;
    if (v.failed || !std::isfinite(v.log_likelihood)) continue;
    const double log_ratio = setup.beta * (v.log_likelihood - task.log_likelihood);
    if (!(task.log_likelihood > -kInf) || std::log(u) < log_ratio) {
      task.theta = proposal;
      task.log_likelihood = v.log_likelihood;
      task.state = std::move(out);
      ++task.accepted;
    }
  }
}

Executor omp_executor(const PriorBox& prior, const Likelihood& likelihood, int threads,
                      CancelCheck cancel) {
  return [&prior, &likelihood, threads, cancel](const StageSetup& setup,
                                                std::vector<ChainTask>& tasks) {
    const int n = static_cast<int>(tasks.size());
    const int nt = threads > 0 ? threads : omp_get_max_threads();
    std::exception_ptr error;
    std::atomic<bool> stop{false};
#pragma omp parallel num_threads(nt)
    {
      // Inner parallel regions (the likelihood's assembly loops) at one thread, also when
      // nt = 1: the forward model's sums must not depend on the thread count.
      omp_set_num_threads(1);
#pragma omp for schedule(dynamic)
      for (int i = 0; i < n; ++i) {
        if (stop.load(std::memory_order_relaxed)) continue;
        try {
          if (cancel && cancel()) {
            stop = true;
            continue;
          }
          run_chain(setup, prior, likelihood, tasks[i]);
        } catch (...) {
          stop = true;
#pragma omp critical(rbc_tmcmc_error)
          if (!error) error = std::current_exception();
        }
      }
    }
    if (error) std::rethrow_exception(error);
    if (stop) throw Cancelled();
  };
}

const std::vector<double>& SamplerState::accumulator(const std::string& name) const {
  for (const auto& [key, values] : accumulators)
    if (key == name) return values;
  throw std::invalid_argument("sampler state has no accumulator '" + name + "'");
}

double weight_cov(const Eigen::VectorXd& l, double db) {
  double lmax = -kInf;
  for (int i = 0; i < l.size(); ++i)
    if (l(i) > lmax) lmax = l(i);
  if (!(lmax > -kInf)) return kInf;
  double s = 0, s2 = 0;
  for (int i = 0; i < l.size(); ++i) {
    const double w = l(i) > -kInf ? std::exp(db * (l(i) - lmax)) : 0.0;
    s += w;
    s2 += w * w;
  }
  const double n = static_cast<double>(l.size());
  const double mean = s / n;
  const double var = std::max(0.0, s2 / n - mean * mean);
  return std::sqrt(var) / mean;
}

double next_tempering_exponent(const Eigen::VectorXd& l, double beta, double target) {
  const double full = 1.0 - beta;
  if (weight_cov(l, full) <= target) return 1.0;
  double lo = 0.0, hi = full;
  for (int it = 0; it < 200 && hi - lo > 1e-15 * std::max(1.0, hi); ++it) {
    const double mid = 0.5 * (lo + hi);
    (weight_cov(l, mid) < target ? lo : hi) = mid;
  }
  return beta + std::max(hi, 1e-300);
}

namespace {
constexpr const char* kIslandAccumulator = "log_evidence_island";
constexpr const char* kDeltaAccumulator = "delta_method_variance";

/// Throws std::invalid_argument unless `s` can continue a run of these options and prior.
void check_resume_state(const SamplerState& s, const PriorBox& prior, const TmcmcOptions& o) {
  const auto refuse = [](const std::string& what) {
    throw std::invalid_argument("cannot continue the stored sampler state: " + what);
  };
  if (s.sampler != "tmcmc") refuse("it was written by sampler '" + s.sampler + "', not tmcmc");
  const int n = o.samples, d = prior.dimension();
  if (s.theta.rows() != n || s.theta.cols() != d)
    refuse("population of " + std::to_string(s.theta.rows()) + " x " +
           std::to_string(s.theta.cols()) + ", expected " + std::to_string(n) + " x " +
           std::to_string(d));
  if (s.log_likelihood.size() != n || static_cast<int>(s.states.size()) != n)
    refuse("log-likelihoods or warm states do not match the population");
  if (s.stage < 0 || static_cast<int>(s.schedule.size()) != s.stage + 1 ||
      static_cast<int>(s.stages.size()) != s.stage + 1)
    refuse("schedule or stage log does not match stage " + std::to_string(s.stage));
  if (s.schedule.front() != 0.0 || !(s.schedule.back() <= 1.0))
    refuse("tempering schedule does not run from 0 towards 1");
  if (static_cast<int>(s.accumulator(kIslandAccumulator).size()) != o.islands)
    refuse(std::to_string(s.accumulator(kIslandAccumulator).size()) + " islands, expected " +
           std::to_string(o.islands));
  if (s.accumulator(kDeltaAccumulator).size() != 1) refuse("malformed accumulators");
  for (int i = 0; i < n; ++i) {
    std::vector<double> theta(d);
    for (int k = 0; k < d; ++k) theta[k] = s.theta(i, k);
    if (!prior.contains(theta))
      refuse("sample " + std::to_string(i) + " lies outside the prior box");
  }
}
}  // namespace

TmcmcResult run_tmcmc(const Likelihood& likelihood, const PriorBox& prior,
                      const TmcmcOptions& options, const Executor& executor_in,
                      const StageCallback& on_stage) {
  return run_tmcmc(likelihood, prior, options, executor_in, on_stage, TmcmcContinuation{});
}

TmcmcResult run_tmcmc(const Likelihood& likelihood, const PriorBox& prior,
                      const TmcmcOptions& options, const Executor& executor_in,
                      const StageCallback& on_stage, const TmcmcContinuation& continuation) {
  options.validate();
  prior.validate();
  if (prior.dimension() != likelihood.dimension())
    throw std::invalid_argument("prior box has " + std::to_string(prior.dimension()) +
                                " coordinates but the likelihood " +
                                std::to_string(likelihood.dimension()));
  const SamplerState* resume = continuation.resume;
  if (resume) check_resume_state(*resume, prior, options);
  const auto t0 = std::chrono::steady_clock::now();
  // A continued run's clock goes on from the stored stage's (timing only: never compared).
  const double elapsed_before = resume ? resume->stages.back().elapsed_s : 0.0;
  const auto elapsed = [&] {
    return elapsed_before +
           std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  const Executor executor = executor_in ? executor_in : omp_executor(prior, likelihood);
  const int n = options.samples, d = prior.dimension();
  TmcmcResult result;

  std::vector<ChainTask> tasks(n);
  StageSetup setup;
  setup.seed = options.seed;
  double beta = 0, var_log_z = 0;
  const int islands = options.islands;
  const auto island_begin = [n, islands](int b) {
    return static_cast<int>(static_cast<long long>(b) * n / islands);
  };
  std::vector<double> log_z_island(islands, 0.0);
  std::vector<double> schedule = {0.0};
  int stage = 0;
  auto collect = [&](StageInfo& info) {
    long long proposed = 0, accepted = 0;
    for (const auto& t : tasks) {
      result.counts += t.counts;
      proposed += t.proposed;
      accepted += t.accepted;
    }
    info.acceptance = proposed ? static_cast<double>(accepted) / proposed : 0.0;
    info.forward_runs = result.counts.runs;
    info.elapsed_s = elapsed();
  };
  // The state after a completed stage, handed to the checkpoint callback.
  auto hand_out_state = [&] {
    if (!continuation.checkpoint) return;
    SamplerState s;
    s.stage = stage;
    s.theta.resize(n, d);
    s.log_likelihood.resize(n);
    s.states.resize(n);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < d; ++k) s.theta(i, k) = tasks[i].theta[k];
      s.log_likelihood(i) = tasks[i].log_likelihood;
      s.states[i] = tasks[i].state;
    }
    s.schedule = schedule;
    s.accumulators = {{kIslandAccumulator, log_z_island}, {kDeltaAccumulator, {var_log_z}}};
    s.counts = result.counts;
    s.stages = result.stages;
    continuation.checkpoint(s);
  };
  if (resume) {
    for (int i = 0; i < n; ++i) {
      tasks[i].index = i;
      tasks[i].theta.resize(d);
      for (int k = 0; k < d; ++k) tasks[i].theta[k] = resume->theta(i, k);
      tasks[i].log_likelihood = resume->log_likelihood(i);
      tasks[i].state = resume->states[i];
    }
    stage = resume->stage;
    schedule = resume->schedule;
    beta = schedule.back();
    log_z_island = resume->accumulator(kIslandAccumulator);
    var_log_z = resume->accumulator(kDeltaAccumulator).front();
    result.counts = resume->counts;
    result.stages = resume->stages;
  } else {
    // Stage 0: prior draws.
    for (int i = 0; i < n; ++i) {
      NormalStream rng(stream_seed(options.seed, 0, i, kPriorDraw));
      tasks[i].index = i;
      tasks[i].theta.resize(d);
      for (int k = 0; k < d; ++k)
        tasks[i].theta[k] = prior.lower[k] + rng.uniform() * (prior.upper[k] - prior.lower[k]);
    }
    executor(setup, tasks);
    StageInfo info;
    info.unique_fraction = 1.0;
    collect(info);
    result.stages.push_back(info);
    hand_out_state();
    if (on_stage) on_stage(info);
  }
  Eigen::VectorXd l(n);
  auto failed_too_often = [&] {
    return result.counts.runs > 0 &&
           static_cast<double>(result.counts.failed) >
               options.max_failure_fraction * static_cast<double>(result.counts.runs);
  };
  while (beta < 1.0) {
    throw_if_cancelled(options.cancel);
    if (failed_too_often()) {
      result.status = TmcmcStatus::failed_runs;
      break;
    }
    if (stage >= options.max_stages) {
      result.status = TmcmcStatus::max_stages;
      break;
    }
    for (int i = 0; i < n; ++i) l(i) = tasks[i].log_likelihood;
    const double next = next_tempering_exponent(l, beta, options.target_cov);
    const double db = next - beta;
    // Weights relative to the largest log-likelihood, the evidence increment, the moments.
    const double lmax = l.maxCoeff();
    if (!(lmax > -kInf)) throw std::runtime_error("TMCMC: every sample has zero likelihood");
    Eigen::VectorXd w(n);
    for (int i = 0; i < n; ++i) w(i) = l(i) > -kInf ? std::exp(db * (l(i) - lmax)) : 0.0;
    StageInfo info;
    info.cov = weight_cov(l, db);
    info.log_mean_weight = std::log(w.sum() / n) + db * lmax;
    // Per island: its evidence increment and its normalised weights (each island carries
    // mass 1/B in the moments, so all islands count alike).
    Eigen::VectorXd p(n);
    std::vector<double> island_sum(islands, 0.0);
    for (int b = 0; b < islands; ++b) {
      for (int i = island_begin(b); i < island_begin(b + 1); ++i) island_sum[b] += w(i);
      const int nb = island_begin(b + 1) - island_begin(b);
      log_z_island[b] += island_sum[b] > 0 ? std::log(island_sum[b] / nb) + db * lmax : -kInf;
      for (int i = island_begin(b); i < island_begin(b + 1); ++i)
        p(i) = island_sum[b] > 0 ? w(i) / (island_sum[b] * islands) : 0.0;
    }
    var_log_z += info.cov * info.cov / n;
    p /= p.sum();  // a dead island (all weights zero) gives its mass to the others
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(d);
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < d; ++k) mean(k) += p(i) * tasks[i].theta[k];
    Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(d, d);
    for (int i = 0; i < n; ++i) {
      Eigen::VectorXd dx(d);
      for (int k = 0; k < d; ++k) dx(k) = tasks[i].theta[k] - mean(k);
      cov += p(i) * dx * dx.transpose();
    }
    // Keep the proposal proper when the population collapses onto few points.
    for (int k = 0; k < d; ++k) cov(k, k) += 1e-12 * std::pow(prior.upper[k] - prior.lower[k], 2);
    ++stage;
    setup.stage = stage;
    setup.beta = next;
    setup.chain_length = options.chain_length;
    setup.proposal_chol =
        Eigen::LLT<Eigen::MatrixXd>(options.proposal_scale * options.proposal_scale * cov)
            .matrixL();
    // Multinomial resampling within each island (a dead island draws from all samples):
    // sorted uniforms walked along the cumulative weights.
    std::vector<ChainTask> next_tasks(n);
    int unique = 0;
    for (int b = 0; b < islands; ++b) {
      const bool dead = !(island_sum[b] > 0);
      const int from = dead ? 0 : island_begin(b), to = dead ? n : island_begin(b + 1);
      const int slots = island_begin(b + 1) - island_begin(b);
      NormalStream rng(stream_seed(options.seed, stage, b, kResample));
      std::vector<double> u(slots);
      for (auto& x : u) x = rng.uniform();
      std::sort(u.begin(), u.end());
      double mass = 0;
      for (int i = from; i < to; ++i) mass += p(i);
      double cum = 0;
      int parent = from, last_parent = -1;
      for (int s = 0; s < slots; ++s) {
        const double target = u[s] * mass;
        while (parent < to - 1 && cum + p(parent) < target) cum += p(parent++);
        while (p(parent) == 0 && parent < to - 1) ++parent;  // never a zero-weight parent
        while (p(parent) == 0 && parent > from) --parent;
        const int k = island_begin(b) + s;
        next_tasks[k].index = k;
        next_tasks[k].theta = tasks[parent].theta;
        next_tasks[k].log_likelihood = tasks[parent].log_likelihood;
        next_tasks[k].state = tasks[parent].state;
        unique += parent != last_parent;
        last_parent = parent;
      }
    }
    tasks = std::move(next_tasks);
    executor(setup, tasks);
    beta = next;
    schedule.push_back(beta);
    info.stage = stage;
    info.beta = beta;
    info.unique_fraction = static_cast<double>(unique) / n;
    collect(info);
    result.stages.push_back(info);
    hand_out_state();
    if (on_stage) on_stage(info);
  }
  if (result.status == TmcmcStatus::converged && failed_too_often())
    result.status = TmcmcStatus::failed_runs;
  if (islands == 1) {
    result.log_evidence = log_z_island[0];
    result.log_evidence_sd = std::sqrt(var_log_z);
  } else {
    // log Z = log mean_b Z_b; sd from the islands' scatter: sd_b(log Z_b) / sqrt(B).
    const double top = *std::max_element(log_z_island.begin(), log_z_island.end());
    double sum = 0, m = 0, m2 = 0;
    for (double z : log_z_island) {
      sum += std::exp(z - top);
      m += z / islands;
    }
    for (double z : log_z_island) m2 += (z - m) * (z - m);
    result.log_evidence = top + std::log(sum / islands);
    result.log_evidence_sd = std::sqrt(m2 / (islands - 1) / islands);
  }
  result.samples.resize(n, d);
  result.log_likelihood.resize(n);
  result.states.resize(n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < d; ++k) result.samples(i, k) = tasks[i].theta[k];
    result.log_likelihood(i) = tasks[i].log_likelihood;
    result.states[i] = std::move(tasks[i].state);
  }
  result.wall_s = elapsed();
  return result;
}

}  // namespace rbc
