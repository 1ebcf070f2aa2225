// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/mc_run.hpp"

#include <gsl/gsl_cdf.h>
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "core/geometry.hpp"
#include "core/validation.hpp"
#include "discrete/hmc_sampler.hpp"
#include "discrete/stretch.hpp"

namespace rbc {

const std::vector<std::string>& mc_sample_columns() {
  static const std::vector<std::string> names = {"sweep",         "energy_pNum", "axial_um",
                                                 "transverse_um", "area_um2",    "volume_um3",
                                                 "acceptance",    "step_um"};
  return names;
}

std::vector<double> to_row(const McSample& s) {
  return {double(s.sweep), s.energy_pNum, s.axial_um,   s.transverse_um,
          s.area_um2,      s.volume_um3,  s.acceptance, s.step_um};
}

McSample sample_from_row(const double* r) {
  McSample s;
  s.sweep = static_cast<long long>(std::llround(r[0]));
  s.energy_pNum = r[1];
  s.axial_um = r[2];
  s.transverse_um = r[3];
  s.area_um2 = r[4];
  s.volume_um3 = r[5];
  s.acceptance = r[6];
  s.step_um = r[7];
  return s;
}

void McRunSetup::validate() const {
  sampler.validate();
  validate_discrete_force(force_pN);
  // 1e4 x the network's own stiffness already pins A and V to ~1e-6 at 300 K.
  require_finite_in_range("penalty scale", "", penalty_scale, 0.0, 1e4);
  require_integer_in_range("sample interval (sweeps)", sample_every, 1,
                           std::numeric_limits<int>::max());
  require_integer_in_range("chains", sampler.chains, 1, kMaxMcChains);
}

unsigned long mc_chain_seed(unsigned long seed, int chain) {
  if (chain == 0) return seed;
  // SplitMix64 (Steele, Lea & Flood 2014) of the seed, then of that plus the chain index: the
  // low 32 bits (all GSL's mt19937 seeding reads) of different chains differ.
  auto splitmix64 = [](std::uint64_t z) {
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  return static_cast<unsigned long>(
      splitmix64(splitmix64(std::uint64_t(seed)) + std::uint64_t(chain)));
}

namespace {

/// Normal scores of the ranks of all draws (average ranks for ties), same shape as `chains`.
std::vector<std::vector<double>> rank_normalise(const std::vector<std::vector<double>>& chains) {
  std::vector<std::pair<double, std::size_t>> all;
  for (std::size_t c = 0; c < chains.size(); ++c)
    for (std::size_t i = 0; i < chains[c].size(); ++i)
      all.emplace_back(chains[c][i], c * chains[0].size() + i);
  std::sort(all.begin(), all.end());
  const double n = double(all.size());
  std::vector<std::vector<double>> z(chains.size(), std::vector<double>(chains[0].size()));
  for (std::size_t a = 0; a < all.size();) {
    std::size_t b = a;
    while (b < all.size() && all[b].first == all[a].first) ++b;
    const double rank = 0.5 * double(a + 1 + b);  // average of ranks a+1 .. b
    const double score = gsl_cdf_ugaussian_Pinv((rank - 0.375) / (n + 0.25));
    for (std::size_t k = a; k < b; ++k) {
      const std::size_t idx = all[k].second;
      z[idx / chains[0].size()][idx % chains[0].size()] = score;
    }
    a = b;
  }
  return z;
}

/// Classic R-hat sqrt(((n - 1)/n W + B/n) / W) of equally long chains.
double classic_rhat(const std::vector<std::vector<double>>& chains) {
  const double n = double(chains[0].size()), m = double(chains.size());
  std::vector<double> means;
  double w = 0;
  for (const auto& c : chains) {
    const double mean = std::accumulate(c.begin(), c.end(), 0.0) / n;
    double v = 0;
    for (double x : c) v += (x - mean) * (x - mean);
    w += v / (n - 1);
    means.push_back(mean);
  }
  w /= m;
  const double grand = std::accumulate(means.begin(), means.end(), 0.0) / m;
  double b = 0;
  for (double x : means) b += (x - grand) * (x - grand);
  b *= n / (m - 1);
  if (w == 0) return b == 0 ? 1.0 : std::numeric_limits<double>::infinity();
  return std::sqrt(((n - 1) / n * w + b / n) / w);
}

}  // namespace

double split_rhat(const std::vector<std::vector<double>>& chains) {
  if (chains.empty() || chains[0].size() < 4)
    throw std::invalid_argument("split R-hat needs at least one chain of at least 4 draws");
  const std::size_t n = chains[0].size(), half = n / 2;
  std::vector<std::vector<double>> split;
  for (const auto& c : chains) {
    if (c.size() != n) throw std::invalid_argument("split R-hat needs equally long chains");
    split.emplace_back(c.begin(), c.begin() + std::ptrdiff_t(half));
    split.emplace_back(c.end() - std::ptrdiff_t(half), c.end());
  }
  std::vector<double> all;
  for (const auto& c : split) all.insert(all.end(), c.begin(), c.end());
  std::sort(all.begin(), all.end());
  const std::size_t s = all.size();
  const double median = s % 2 ? all[s / 2] : 0.5 * (all[s / 2 - 1] + all[s / 2]);
  std::vector<std::vector<double>> folded = split;
  for (auto& c : folded)
    for (double& x : c) x = std::abs(x - median);
  return std::max(classic_rhat(rank_normalise(split)), classic_rhat(rank_normalise(folded)));
}

std::vector<double> mc_startup_forces(double force_pN) {
  if (!(force_pN >= 0) || !std::isfinite(force_pN))
    throw std::invalid_argument("start-up force must be finite and >= 0 pN, got " +
                                std::to_string(force_pN) + " pN");
  constexpr double kLinearUpTo_pN = 200.0, kLinearStep_pN = 40.0, kRatio = 1.2;
  std::vector<double> f;
  const double linear_end = std::min(force_pN, kLinearUpTo_pN);
  const int linear = std::max(1, static_cast<int>(std::ceil(linear_end / kLinearStep_pN)));
  for (int k = 1; k <= linear; ++k) f.push_back(linear_end * k / linear);
  if (force_pN > kLinearUpTo_pN) {
    const int geometric =
        static_cast<int>(std::ceil(std::log(force_pN / kLinearUpTo_pN) / std::log(kRatio)));
    for (int k = 1; k <= geometric; ++k)
      f.push_back(kLinearUpTo_pN * std::pow(force_pN / kLinearUpTo_pN, double(k) / geometric));
    f.back() = force_pN;  // (up to 200 pN the last entry is F k/k exactly)
  }
  return f;
}

namespace {
LoadState load_of(const McRunSetup& s) {
  LoadState l;
  l.force_pN = s.force_pN;
  l.multipliers = s.multipliers;
  l.stiffness_scale = s.penalty_scale;
  return l;
}
}  // namespace

McRun::McRun(const Network& net, const McRunSetup& setup, const Positions& start)
    : net_(net), setup_(setup) {
  make_chains(nullptr, &start);
}

McRun::McRun(const Network& net, const McRunSetup& setup, const McChainState& state,
             std::vector<McSample> series)
    : net_(net), setup_(setup) {
  if (setup_.sampler.chains != 1)
    throw std::invalid_argument("one chain state given for a run of " +
                                std::to_string(setup_.sampler.chains) + " chains");
  const std::vector<McChainState> states{state};
  series_.push_back(std::move(series));
  make_chains(&states, nullptr);
}

McRun::McRun(const Network& net, const McRunSetup& setup, const std::vector<McChainState>& states,
             std::vector<std::vector<McSample>> series)
    : net_(net), setup_(setup), series_(std::move(series)) {
  if (states.size() != std::size_t(setup_.sampler.chains) || series_.size() != states.size())
    throw std::invalid_argument(std::to_string(states.size()) + " chain states and " +
                                std::to_string(series_.size()) + " series given for a run of " +
                                std::to_string(setup_.sampler.chains) + " chains");
  make_chains(&states, nullptr);
}

void McRun::make_chains(const std::vector<McChainState>* states, const Positions* start) {
  if (setup_.sampler.algorithm == McAlgorithm::hmc) setup_.sampler.streams = 1;  // one stream
  setup_.validate();
  const int chains = setup_.sampler.chains;
  // The chains' threads: one per chain up to the threads available (McOptions::threads > 0
  // caps them, as it caps a single chain's); a chain beside others runs on one thread.
  const int available =
      setup_.sampler.threads > 0 ? setup_.sampler.threads : std::max(1, omp_get_max_threads());
  threads_.requested = available;
  threads_.threads = std::max(1, std::min(chains, available));
  threads_.reason = std::to_string(threads_.threads) + ": " + std::to_string(chains) +
                    (chains == 1 ? " chain" : " independent chains") +
                    (threads_.threads > 1 ? ", one per thread, each chain on one thread"
                                          : ", one after the other");
  if (series_.empty()) series_.resize(std::size_t(chains));
  for (int c = 0; c < chains; ++c) {
    McOptions o = setup_.sampler;
    o.seed = mc_chain_seed(setup_.sampler.seed, c);
    if (threads_.threads > 1) o.threads = 1;
    LoadState load = load_of(setup_);
    std::unique_ptr<McChain> chain;
    if (states) {
      const McChainState& st = (*states)[std::size_t(c)];
      if (o.algorithm == McAlgorithm::hmc) {
        if (st.mass_reference.cols() != net_.topo.num_vertices)
          throw std::invalid_argument("HMC chain state has no mass reference positions");
        chain = std::make_unique<HmcSampler>(net_, load, st.x, st.mass_reference, o);
      } else {
        chain = std::make_unique<McSampler>(net_, load, st.x, o);
      }
      chain->restore(st);
    } else if (o.algorithm == McAlgorithm::hmc) {
      chain = std::make_unique<HmcSampler>(net_, load, *start, o);
    } else {
      chain = std::make_unique<McSampler>(net_, load, *start, o);
    }
    chains_.push_back(std::move(chain));
  }
  if (chains == 1) threads_ = chains_[0]->thread_decision();  // the chain's own decision
}

std::vector<McChainState> McRun::states() const {
  std::vector<McChainState> s;
  for (const auto& c : chains_) s.push_back(c->state());
  return s;
}

long long McRun::sweeps_done() const {
  long long s = std::numeric_limits<long long>::max();
  for (const auto& c : chains_) s = std::min(s, c->sweeps_done());
  return s;
}

McSample McRun::measure(const McChain& chain, const McSweepStats& st, double step) const {
  McSample s;
  const Positions& x = chain.positions();
  s.sweep = chain.sweeps_done();
  // The sampler's fixed-order sums (not network_energy / total_area, whose parallel reductions
  // are not bit-reproducible), so a resumed run reproduces the series bit for bit.
  s.energy_pNum = chain.energy();
  const Diameters d = measure_diameters(x);
  s.axial_um = d.axial_um;
  s.transverse_um = d.transverse_um;
  s.area_um2 = chain.area_um2();
  s.volume_um3 = chain.volume_um3();
  s.acceptance = st.acceptance();
  s.step_um = step;
  return s;
}

bool McRun::advance(long long total_sweeps, const std::function<bool(const McRun&)>& after_sweep) {
  return advance_blocks(total_sweeps, 1, after_sweep);
}

bool McRun::advance_blocks(long long total_sweeps, long long block_sweeps,
                           const std::function<bool(const McRun&)>& after_block) {
  if (block_sweeps < 1)
    throw std::invalid_argument("block of " + std::to_string(block_sweeps) +
                                " sweeps: expected at least 1");
  const int chains = chain_count();
  while (sweeps_done() < total_sweeps) {
    // Between blocks: a cancelled run stops at the last completed sweep (checkpointable).
    throw_if_cancelled(setup_.cancel);
    const long long target =
        std::min(total_sweeps, (sweeps_done() / block_sweeps + 1) * block_sweeps);
    std::atomic<bool> cancelled{false};
    std::vector<std::exception_ptr> failure(static_cast<std::size_t>(chains));
    // One chain per thread (static, chunk 1: chain c on thread c mod threads); the calling
    // thread (thread 0) alone polls the cancel hook, which may need it (Python's GIL).
#pragma omp parallel for schedule(static, 1) num_threads(threads_.threads)
    for (int c = 0; c < chains; ++c) {
      if (threads_.threads > 1) omp_set_num_threads(1);  // nested regions: one thread
      const bool polls = omp_get_thread_num() == 0;
      McChain& chain = *chains_[std::size_t(c)];
      std::vector<McSample>& series = series_[std::size_t(c)];
      try {
        bool first = true;
        while (chain.sweeps_done() < target) {
          if (polls && !first && setup_.cancel && setup_.cancel()) cancelled = true;
          if (cancelled) break;
          first = false;
          const double step = chain.step_um();
          const McSweepStats st = chain.sweep();
          if (chain.sweeps_done() % setup_.sample_every == 0)
            series.push_back(measure(chain, st, step));
        }
      } catch (...) {
        failure[std::size_t(c)] = std::current_exception();
        cancelled = true;
      }
    }
    for (const auto& f : failure)
      if (f) std::rethrow_exception(f);
    if (cancelled) throw Cancelled();
    if (after_block && !after_block(*this)) return false;
  }
  return true;
}

namespace {

/// Pools the chains' results of one observable (see the header).
BlockingResult pool(const std::vector<BlockingResult>& per_chain,
                    const std::vector<std::vector<double>>& samples, McConvergence& check) {
  const double c = double(per_chain.size());
  BlockingResult p;
  double err2 = 0, blocking2 = 0;
  bool converged = true;
  for (const BlockingResult& b : per_chain) {
    p.mean += b.mean;
    err2 += b.error * b.error;
    blocking2 += b.blocking_error * b.blocking_error;
    converged = converged && b.converged;
    p.window = std::max(p.window, b.window);
    p.samples += b.samples;
  }
  p.mean /= c;
  p.error = std::sqrt(err2) / c;
  p.blocking_error = std::sqrt(blocking2) / c;
  p.converged = converged;
  double ss = 0;
  for (const auto& chain : samples)
    for (double x : chain) ss += (x - p.mean) * (x - p.mean);
  p.variance = p.samples > 1 ? ss / double(p.samples - 1) : 0.0;
  p.inefficiency = p.variance > 0 ? double(p.samples) * p.error * p.error / p.variance : 1.0;
  check.rhat = split_rhat(samples);
  check.converged = check.rhat < kMcRhatThreshold;
  check.chain_dof = static_cast<int>(per_chain.size()) - 1;
  if (check.chain_dof > 0) {
    double spread = 0, chi2 = 0;
    for (const BlockingResult& b : per_chain) {
      spread += (b.mean - p.mean) * (b.mean - p.mean);
      if (b.error > 0) chi2 += (b.mean - p.mean) * (b.mean - p.mean) / (b.error * b.error);
    }
    check.between_chain_error = std::sqrt(spread / (c - 1) / c);
    check.chain_chi2 = chi2;
    check.chain_p_value = gsl_cdf_chisq_Q(chi2, double(check.chain_dof));
  }
  return p;
}

}  // namespace

McSummary McRun::summarise() const {
  const int chains = chain_count();
  std::vector<std::vector<McSample>> prod(static_cast<std::size_t>(chains));
  std::size_t shortest = std::numeric_limits<std::size_t>::max();
  for (int c = 0; c < chains; ++c) {
    for (const McSample& s : series_[std::size_t(c)])
      if (s.sweep > setup_.sampler.adapt_sweeps) prod[std::size_t(c)].push_back(s);
    shortest = std::min(shortest, prod[std::size_t(c)].size());
  }
  if (shortest < 8)
    throw std::invalid_argument("too few production samples for statistics (" +
                                std::to_string(shortest) + " < 8): run more sweeps");
  // Chains cancelled mid-block may hold a few more samples than others: each contributes the
  // first `shortest`, so every chain covers the same sweeps.
  for (auto& p : prod) p.resize(shortest);
  McSummary m;
  m.chains = chains;
  for (const auto& p : prod) {
    std::vector<double> e;
    for (const McSample& s : p) e.push_back(s.energy_pNum);
    m.discarded = std::max(m.discarded, detect_equilibration(e).start);
  }
  m.samples = std::size_t(chains) * shortest;
  auto column = [&](double McSample::*field, BlockingResult McChainSummary::*out,
                    McConvergence& check) {
    std::vector<std::vector<double>> all;
    std::vector<BlockingResult> per;
    for (int c = 0; c < chains; ++c) {
      std::vector<double> v;
      for (std::size_t i = m.discarded; i < shortest; ++i)
        v.push_back(prod[std::size_t(c)][i].*field);
      per.push_back(correlated_mean(v));
      m.per_chain[std::size_t(c)].*out = per.back();
      all.push_back(std::move(v));
    }
    return pool(per, all, check);
  };
  m.per_chain.resize(std::size_t(chains));
  for (int c = 0; c < chains; ++c)
    m.per_chain[std::size_t(c)].seed = mc_chain_seed(setup_.sampler.seed, c);
  m.energy = column(&McSample::energy_pNum, &McChainSummary::energy, m.energy_check);
  m.axial = column(&McSample::axial_um, &McChainSummary::axial, m.axial_check);
  m.transverse = column(&McSample::transverse_um, &McChainSummary::transverse, m.transverse_check);
  m.area = column(&McSample::area_um2, &McChainSummary::area, m.area_check);
  m.volume = column(&McSample::volume_um3, &McChainSummary::volume, m.volume_check);
  m.converged = m.energy_check.converged && m.axial_check.converged &&
                m.transverse_check.converged && m.area_check.converged && m.volume_check.converged;
  double acc = 0;
  for (int c = 0; c < chains; ++c) {
    double chain_acc = 0;
    for (std::size_t i = m.discarded; i < shortest; ++i) {
      const McSample& s = prod[std::size_t(c)][i];
      chain_acc += s.acceptance;
      m.max_area_drift =
          std::max(m.max_area_drift, std::abs(s.area_um2 - net_.area0_um2) / net_.area0_um2);
      m.max_volume_drift = std::max(m.max_volume_drift,
                                    std::abs(s.volume_um3 - net_.volume0_um3) / net_.volume0_um3);
    }
    m.per_chain[std::size_t(c)].acceptance = chain_acc / double(shortest - m.discarded);
    acc += m.per_chain[std::size_t(c)].acceptance;
  }
  m.acceptance = acc / double(chains);
  return m;
}

}  // namespace rbc
