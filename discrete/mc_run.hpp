// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A Monte Carlo run of the network: the sampler plus its time series of observables, in a form
// that can be checkpointed at any sweep boundary and resumed bit for bit
// (discrete/mc_checkpoint.hpp).
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

/// Means with errors over the production samples (correlated_mean of each column).
struct McSummary {
  std::size_t samples = 0;    ///< recorded production samples
  std::size_t discarded = 0;  ///< of those, discarded as the transient (equilibration)
  BlockingResult energy, axial, transverse, area, volume;
  double acceptance = 0;                            ///< mean over the production sweeps
  double max_area_drift = 0, max_volume_drift = 0;  ///< largest |G - G0|/G0 in the samples
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
  /// Fresh run from `start`.
  McRun(const Network& net, const McRunSetup& setup, const Positions& start);
  /// Resumes from a chain state and the series recorded so far.
  McRun(const Network& net, const McRunSetup& setup, const McChainState& state,
        std::vector<McSample> series);

  /// Runs sweeps until `total_sweeps` are done; after_sweep (if given) is called after each.
  /// Stops early (returns false) when after_sweep returns false. Polls setup().cancel before
  /// every sweep and throws Cancelled when it returns true; the run then stands at the last
  /// completed sweep (state() and series() are consistent and can be checkpointed).
  bool advance(long long total_sweeps, const std::function<bool(const McRun&)>& after_sweep = {});

  /// The chain (McSampler or HmcSampler, as setup().sampler.algorithm says).
  const McChain& sampler() const { return *sampler_; }
  const McRunSetup& setup() const { return setup_; }
  const std::vector<McSample>& series() const { return series_; }
  McChainState state() const { return sampler_->state(); }
  /// Statistics over the samples after the adaptive phase, with the transient detected on the
  /// energy series (detect_equilibration) discarded; means and errors by correlated_mean
  /// (integrated autocorrelation time, discrete/mc_observables.hpp). Needs >= 8 production
  /// samples.
  McSummary summarise() const;

 private:
  McSample measure(const McSweepStats& st, double step) const;
  const Network& net_;
  McRunSetup setup_;
  std::unique_ptr<McChain> sampler_;
  std::vector<McSample> series_;
};

}  // namespace rbc
