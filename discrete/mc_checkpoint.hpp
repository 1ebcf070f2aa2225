// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Checkpoint and restart of a Monte Carlo run in HDF5 (core/h5file.hpp). The file holds
// everything that defines the chain at a sweep boundary, so a resumed run continues the SAME
// chain bit for bit: positions, the raw GSL mt19937 state of every stream (gsl_rng_state bytes),
// the step size, the sweep count, the run setup (temperature, force, fixed multipliers, seed,
// streams, adaptive sweeps, sample interval) and the time series so far. A fingerprint of the
// network (vertex and face counts, a hash of the faces, rest positions, bending, links, steric
// term and bead patch) refuses a checkpoint written for another network. Written atomically
// (temporary file + rename).
//
// Layout (format 7): root attributes format, chains, sweep (the fewest of a chain), series_rows
// (samples of all chains), fingerprint, vertices, bending_model,
// faces, rng_type, rng_bytes, temperature_K, force_pN, lambda_area_pN_per_um,
// lambda_volume_pN_per_um2, seed (the run's; chain c's is mc_chain_seed(seed, c)), streams,
// adapt_sweeps, sample_every, penalty_scale, target_acceptance, adapt_gain, reference_axial_um,
// reference_transverse_um, planned_sweeps, adapt_fraction, sampler (metropolis or hmc),
// content_checksum; /mobile; /chain_sweeps and /chain_series_rows (chains x 1, uint64) and
// /chain_steps (chains x 1; Metropolis: trial half-width in um, HMC: leapfrog step); and per
// chain c the group /chain_c with positions_um (N x 3), rng_state (streams x words, uint64,
// little-endian packing of the gsl_rng_state bytes), series (samples x 8, see
// mc_sample_columns()) and, for HMC, mass_reference_um (N x 3, the positions its mass matrix was
// built at). HMC runs add the attributes hmc_step, hmc_trajectory_time, hmc_jitter,
// hmc_target_acceptance, hmc_adapt_gain, hmc_max_steps, hmc_projected_mass,
// hmc_mass_shift_fraction, and hmc_mass_reference ("thermal"; absent: equilibrium); a thermal
// chain checkpointed inside its averaging window adds /chain_c/mass_reference_sum_um (N x 3, the
// sum of its positions over the window so far). Other format versions are refused with a message
// naming the version.
#include <cstdint>
#include <string>
#include <utility>

#include "discrete/mc_run.hpp"

namespace rbc {

/// FNV-1a 64-bit hash of (N, F, faces, rest positions, bending model and constants): identifies
/// the network a chain runs on.
std::uint64_t network_fingerprint(const Network& net);

/// Where the absolute adaptation length (McOptions::adapt_sweeps) came from, so that a resumed
/// run that extends the chain can say whether it still matches a straight run of the new length.
struct McSchedule {
  long long planned_sweeps = 0;  ///< total sweeps of the run that fixed adapt_sweeps
  double adapt_fraction = -1.0;  ///< adapt_sweeps = round(fraction x planned); -1: given absolute
};

/// A run at a sweep boundary. `chains` and `chain_series` hold every chain (chain order);
/// `chain` and `series` are chain 0's (what a one-chain run needs). write_mc_checkpoint() writes
/// `chains` when it is not empty, else the one chain {chain}; read_mc_checkpoint() fills all.
struct McCheckpoint {
  McRunSetup setup;
  McChainState chain;
  std::vector<McSample> series;
  McSchedule schedule;
  std::vector<McChainState> chains;
  std::vector<std::vector<McSample>> chain_series;
  McCheckpoint() = default;
  /// One chain.
  McCheckpoint(McRunSetup s, McChainState c, std::vector<McSample> t, McSchedule sch = {})
      : setup(std::move(s)), chain(std::move(c)), series(std::move(t)), schedule(sch) {}
  /// Every chain of a run (c and t non-empty, equally long).
  McCheckpoint(McRunSetup s, std::vector<McChainState> c, std::vector<std::vector<McSample>> t,
               McSchedule sch = {})
      : setup(std::move(s)),
        chain(c.at(0)),
        series(t.at(0)),
        schedule(sch),
        chains(std::move(c)),
        chain_series(std::move(t)) {}
  /// The checkpoint of every chain of `run`.
  static McCheckpoint of(const McRun& run, McSchedule sch = {}) {
    return McCheckpoint(run.setup(), run.states(), run.all_series(), sch);
  }
};

/// Writes the checkpoint atomically; throws std::runtime_error naming the path on failure
/// (no partial file is left at `path`), std::invalid_argument when the chains do not match
/// setup.sampler.chains.
void write_mc_checkpoint(const std::string& path, const Network& net, const McCheckpoint& cp);

/// What a checkpoint says about its network, so a resumed run can rebuild the same one.
struct McCheckpointNetwork {
  int vertices = 0;  ///< actual vertex count (a valid rest-shape target: it reproduces the mesh)
  BendingModel bending_model = BendingModel::juelicher;
  McAlgorithm algorithm = McAlgorithm::metropolis;  ///< the chain's sampler
};
/// Reads those attributes; throws std::runtime_error naming the file when it is missing or
/// corrupt.
McCheckpointNetwork peek_mc_checkpoint_network(const std::string& path);

/// Reads and checks a checkpoint against `net`. Throws std::runtime_error for a missing or
/// corrupt file (naming it and what is wrong) and std::invalid_argument for a checkpoint of
/// another network (fingerprint mismatch). Corrupt includes contents that match their checksum
/// but not each other (check_mc_checkpoint_arrays): e.g. a sweep count that disagrees with the
/// stored time series and its sample interval.
McCheckpoint read_mc_checkpoint(const std::string& path, const Network& net);

}  // namespace rbc
