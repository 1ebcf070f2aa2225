// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A Monte Carlo run of the network: a fixed number of independent chains (McOptions::chains,
// each a McSampler or HmcSampler with its own seed, all started at the same state) plus their
// time series of observables, in a form that can be checkpointed at any sweep boundary and
// resumed bit for bit (discrete/mc_checkpoint.hpp).
//
// Threads. The chains run in parallel, one per OpenMP thread (min(chains, threads) threads;
// with one thread they run one after the other); a chain run beside others runs on one thread
// itself (Metropolis sweeps forced to one thread, nested regions of the HMC energy inactive,
// CHOLMOD's BLAS on one thread), so the cores are not oversubscribed. Each chain depends on its
// seed and options only, so every result is bit-identical for any thread count.
//
// Pooled statistics (McSummary). Every chain drops the same transient (the largest of the
// chains' detect_equilibration starts on the energy), so all chains contribute equally many
// samples. The pooled mean is the mean of the chain means; its standard error combines the
// chains' own autocorrelation-corrected errors (correlated_mean): error = sqrt(sum e_c^2) / C.
// Cross-checks: the between-chain standard error sd(chain means) / sqrt(C), the chi-square of
// the chain means against the pooled one (C - 1 degrees of freedom) and the rank-normalised
// split-R-hat of Vehtari, Gelman, Simpson, Carpenter & Buerkner (2021, Bayesian Analysis 16,
// 667): the larger of the split-R-hat of the rank-normalised draws (bulk) and of the
// rank-normalised |x - median| (tail); a run whose R-hat is kMcRhatThreshold or more is flagged
// as not converged.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/progress.hpp"
#include "discrete/mc_observables.hpp"
#include "discrete/mc_sampler.hpp"

namespace rbc {

/// One row of the time series (recorded after a sweep).
struct McSample {
  long long sweep = 0;
  double energy_pNum = 0;  ///< sampled free energy F (network_energy with the fixed multipliers)
  double axial_um = 0, transverse_um = 0;  ///< D_A, D_T
  double area_um2 = 0, volume_um3 = 0;     ///< the sampler's running totals
  double acceptance = 0;                   ///< of that sweep
  double step_um = 0;                      ///< trial step used in that sweep
};
inline constexpr int kMcSampleColumns = 8;
/// Column names of McSample in order (CSV header / HDF5 column meaning).
const std::vector<std::string>& mc_sample_columns();
std::vector<double> to_row(const McSample& s);
McSample sample_from_row(const double* row);

/// What a run is: the sampler options plus the load and what it is compared with.
struct McRunSetup {
  McOptions sampler;
  double force_pN = 0;
  ConstraintMultipliers multipliers;  ///< held fixed during sampling
  int sample_every = 1;               ///< sweeps between recorded samples (>= 1)
  /// Multiplies the network's area and volume penalty stiffnesses while sampling
  /// (LoadState::stiffness_scale): the thermal spread of A and V falls as 1/sqrt(scale).
  /// The default keeps the relative drift below 1e-4 at 300 K (see mc_sampler.hpp).
  double penalty_scale = 25.0;
  /// Zero-temperature equilibrium diameters at this force (um), for the thermal shift.
  double reference_axial_um = 0, reference_transverse_um = 0;
  /// Polled once per sweep; returning true stops the run by throwing Cancelled (the chain is
  /// left at the last completed sweep, so a checkpoint can still be written).
  CancelCheck cancel;
  /// sampler.validate(); force finite in [0, kMaxDiscreteForce_pN] pN (the start is the
  /// zero-temperature equilibrium, discrete/stretch.hpp), sample_every >= 1, penalty_scale
  /// finite in (0, 1e4]. Throws rbc::InvalidParameter.
  void validate() const;
};

/// The seed of chain `chain` of a run seeded with `seed`: `seed` itself for chain 0 (a one-chain
/// run is the chain a single sampler with that seed runs), else a SplitMix64 hash of (seed,
/// chain), distinct in its low 32 bits (the bits GSL's mt19937 seeding reads) from the other
/// chains' seeds.
unsigned long mc_chain_seed(unsigned long seed, int chain);

/// R-hat at or above which a run is flagged as not converged (Vehtari et al. 2021).
inline constexpr double kMcRhatThreshold = 1.01;

/// Rank-normalised split-R-hat (Vehtari et al. 2021) of equally long chains (>= 4 draws each;
/// std::invalid_argument otherwise): each chain is split into halves, the draws of all halves
/// are ranked together (average ranks for ties) and mapped to normal scores
/// Phi^-1((r - 3/8) / (S + 1/4)); the result is the larger of the classic split-R-hat
/// sqrt(((n - 1)/n W + B/n) / W) of those scores (bulk) and of the scores of |x - median|
/// (tail). 1 when every draw is equal; +infinity when each half is constant but they differ.
double split_rhat(const std::vector<std::vector<double>>& chains);

/// How well the chains of a run agree on one observable.
struct McConvergence {
  double rhat = 1;                 ///< split_rhat of the chains' production samples
  double between_chain_error = 0;  ///< sd(chain means) / sqrt(C); 0 for one chain
  /// sum_c (m_c - m)^2 / e_c^2 over the chains (m_c, e_c: a chain's mean and its error), with
  /// C - 1 degrees of freedom, and its upper tail probability (1 for one chain).
  double chain_chi2 = 0;
  int chain_dof = 0;
  double chain_p_value = 1;
  bool converged = true;  ///< rhat < kMcRhatThreshold
};

/// One chain's statistics over the pooled production samples.
struct McChainSummary {
  unsigned long seed = 0;  ///< mc_chain_seed(setup seed, chain)
  BlockingResult energy, axial, transverse, area, volume;
  double acceptance = 0;  ///< mean over the production sweeps used
};

/// Means with errors over the production samples of all chains (pooled as the header says).
struct McSummary {
  std::size_t samples = 0;    ///< recorded production samples, all chains (equal per chain)
  std::size_t discarded = 0;  ///< of each chain's, discarded as the transient (equilibration)
  /// Pooled: mean of the chain means; error sqrt(sum e_c^2) / C; variance of all samples used;
  /// inefficiency n error^2 / variance (n all samples used); converged when every chain's error
  /// estimate converged.
  BlockingResult energy, axial, transverse, area, volume;
  double acceptance = 0;                            ///< mean over the production sweeps
  double max_area_drift = 0, max_volume_drift = 0;  ///< largest |G - G0|/G0 in the samples
  int chains = 1;                                   ///< chains pooled
  std::vector<McChainSummary> per_chain;
  McConvergence energy_check, axial_check, transverse_check, area_check, volume_check;
  /// Every observable's R-hat below kMcRhatThreshold.
  bool converged = true;
};

/// The forces (pN) of the zero-temperature start-up continuation from the rest shape to
/// `force_pN` (>= 0, finite), each solved from the previous equilibrium: steps of at most 40 pN
/// up to 200 pN (so every run up to 200 pN starts exactly as before: ceil(F/40) equal steps),
/// then increments of at most 20 % of the force reached, where the WLC links are stiff and a
/// relative step is what the minimiser can take. The count grows with log F, not F: 1,000 pN
/// takes 5 + 9 = 14 solves and 1e6 pN 5 + 47 = 52 (the 40 pN rule needed 25,000). The last
/// entry is force_pN (up to 200 pN computed as F n / n, as before).
std::vector<double> mc_startup_forces(double force_pN);

class McRun {
 public:
  /// Fresh run of setup.sampler.chains chains from `start`.
  McRun(const Network& net, const McRunSetup& setup, const Positions& start);
  /// Resumes a one-chain run (setup.sampler.chains must be 1; std::invalid_argument otherwise)
  /// from its chain state and the series recorded so far.
  McRun(const Network& net, const McRunSetup& setup, const McChainState& state,
        std::vector<McSample> series);
  /// Resumes every chain (setup.sampler.chains states and series, chain order).
  McRun(const Network& net, const McRunSetup& setup, const std::vector<McChainState>& states,
        std::vector<std::vector<McSample>> series);

  /// Runs sweeps until every chain has done `total_sweeps`, in blocks of one sweep: after each
  /// sweep of all chains, after_sweep (if given) is called. Stops early (returns false) when
  /// after_sweep returns false. Polls setup().cancel before every sweep and throws Cancelled
  /// when it returns true; the run then stands at the last completed sweep (state() and
  /// series() are consistent and can be checkpointed).
  bool advance(long long total_sweeps, const std::function<bool(const McRun&)>& after_sweep = {});
  /// As advance(), in blocks: the chains run in parallel to the next multiple of block_sweeps
  /// (>= 1) or total_sweeps, then after_block is called with every chain at that sweep.
  /// setup().cancel is polled before each block and, by the calling thread, before each of its
  /// chain's sweeps; when it fires the other chains stop before their next sweep, so the
  /// chains may stand at different sweeps (each checkpointable) when Cancelled is thrown.
  bool advance_blocks(long long total_sweeps, long long block_sweeps,
                      const std::function<bool(const McRun&)>& after_block = {});

  int chain_count() const { return static_cast<int>(chains_.size()); }
  /// Chain 0 (McSampler or HmcSampler, as setup().sampler.algorithm says).
  const McChain& sampler() const { return *chains_[0]; }
  /// Chain c, in [0, chain_count()).
  const McChain& chain(int c) const { return *chains_.at(std::size_t(c)); }
  /// The run's setup (the seed is the run's; chain c's is mc_chain_seed(seed, c)).
  const McRunSetup& setup() const { return setup_; }
  /// Chain 0's series.
  const std::vector<McSample>& series() const { return series_[0]; }
  const std::vector<McSample>& series(int c) const { return series_.at(std::size_t(c)); }
  /// Chain 0's state.
  McChainState state() const { return chains_[0]->state(); }
  /// Every chain's state, chain order.
  std::vector<McChainState> states() const;
  /// Every chain's series, chain order.
  const std::vector<std::vector<McSample>>& all_series() const { return series_; }
  /// Fewest sweeps done by a chain.
  long long sweeps_done() const;
  /// Threads the chains run on and why (recorded in the run's outputs).
  const McThreadDecision& thread_decision() const { return threads_; }
  /// Statistics over the samples after the adaptive phase, with the transient discarded (the
  /// largest detect_equilibration start of the chains' energy series, dropped from every
  /// chain); per-chain means and errors by correlated_mean (integrated autocorrelation time,
  /// discrete/mc_observables.hpp), pooled as the header says. Needs >= 8 production samples
  /// per chain.
  McSummary summarise() const;

 private:
  void make_chains(const std::vector<McChainState>* states, const Positions* start);
  McSample measure(const McChain& chain, const McSweepStats& st, double step) const;
  const Network& net_;
  McRunSetup setup_;
  McThreadDecision threads_;
  std::vector<std::unique_ptr<McChain>> chains_;
  std::vector<std::vector<McSample>> series_;
};

}  // namespace rbc
