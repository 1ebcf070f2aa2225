// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The Monte Carlo workflow as `rbc mc` and the Python MonteCarlo run it, as library functions:
// the zero-temperature start (force continuation, discrete/stretch.hpp), the rules a resumed
// checkpoint must satisfy, the summary as JSON and the time-series/snapshot files. The front
// ends only parse, convert units and print.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/progress.hpp"
#include "discrete/mc_checkpoint.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/stretch.hpp"

namespace rbc {

/// Runs its scope on one OpenMP thread (the calling thread's setting, restored on exit): the
/// front ends build the rest shape and the zero-temperature start inside one, so a checkpoint's
/// network fingerprint and start state never depend on the thread count of the run.
class SerialOpenMpScope {
 public:
  SerialOpenMpScope();
  ~SerialOpenMpScope();
  SerialOpenMpScope(const SerialOpenMpScope&) = delete;
  SerialOpenMpScope& operator=(const SerialOpenMpScope&) = delete;

 private:
  int saved_;
};

/// Where the chain starts: the zero-temperature equilibrium at the force, or the rest shape
/// (both with the equilibrium's area/volume multipliers held fixed). Spelled "equilibrium",
/// "rest" on the command line and in Python.
enum class McStart { equilibrium, rest };
std::string to_string(McStart s);
/// Throws std::invalid_argument ("start 'x' is not one of equilibrium, rest").
McStart mc_start_from_string(const std::string& s);

/// How the zero-temperature start is computed.
struct McStartOptions {
  McStart start = McStart::equilibrium;
  /// Options of each zero-temperature solve (the default: StretchOptions{}).
  StretchOptions stretch;
  /// Polled before each continuation step (and by L-BFGS when stretch.minimiser.cancel is
  /// empty); true stops by throwing Cancelled.
  CancelCheck cancel;
};

/// The zero-temperature equilibrium at force_pN by continuation through mc_startup_forces()
/// from the rest shape, and the start state of the chain.
struct McZeroTemperatureStart {
  StretchPoint equilibrium;  ///< the last solve (the failing one when !converged)
  bool converged = false;    ///< every continuation step converged
  Positions start;           ///< chain start (um): the equilibrium or the rest shape
};

/// Solves the continuation; on success fills setup.multipliers and setup.reference_*_um from
/// the equilibrium (setup's other fields untouched). Stops at the first step that does not
/// converge (converged = false; the caller reports equilibrium.status and residual_pN).
McZeroTemperatureStart mc_zero_temperature_start(const Network& net, McRunSetup& setup,
                                                 const McStartOptions& options,
                                                 const ProgressSink& progress = {});

/// What a resumed run asks for; an empty field takes the checkpoint's value.
struct McResumeRequest {
  std::optional<double> force_pN, temperature_K, penalty_scale;
  std::optional<unsigned long> seed;
  std::optional<long long> adapt_sweeps;  ///< absolute adaptive sweeps
  std::optional<double> adapt_fraction;   ///< fraction of total_sweeps
  std::optional<BendingModel> bending_model;
  std::optional<McAlgorithm> algorithm;
  std::optional<int> chains;                 ///< independent chains (McOptions::chains)
  std::optional<HmcAreaVolume> area_volume;  ///< HMC's area and volume (HmcOptions)
  long long total_sweeps = 0;                ///< sweeps the resumed run is to reach
};

/// Compatibility of a checkpoint's network with the request: throws std::invalid_argument
/// ("checkpoint 'F' was run with juelicher bending, not dihedral") when the bending model
/// differs.
void check_mc_resume_network(const McCheckpointNetwork& network, const McResumeRequest& request,
                             const std::string& checkpoint_name);

/// Compatibility of a checkpoint with the request (force, temperature, penalty scale equal to
/// 1e-12 relative, seed and absolute adaptive sweeps equal); throws std::invalid_argument naming
/// the checkpoint, its value and the requested one. Returns a note (empty when none) when the
/// kept adaptive phase (absolute sweeps) differs from the one a straight run of total_sweeps
/// would use: the resumed chain then matches the straight run only up to the shorter phase.
std::string check_mc_resume(const McCheckpoint& checkpoint, const McResumeRequest& request,
                            const std::string& checkpoint_name);

/// The statistics keys of `rbc mc --json` and Python's MonteCarlo.summary(): samples (all
/// chains), samples_per_chain, discarded_transient (per chain), acceptance, chains,
/// energy_pNum / axial_um / transverse_um / area_um2 / volume_um3 ({mean, error, std,
/// inefficiency, blocking_converged, rhat, rhat_converged, between_chain_error, chain_chi2,
/// chain_p_value}: the pooled mean, error and inefficiency 2 tau_int of McSummary, the chains'
/// error convergence under the key name kept, and McConvergence), rhat_method, rhat_threshold,
/// converged (every R-hat below the threshold), thermal_shift_axial_um (and _error),
/// thermal_shift_transverse_um (and _error), max_area_drift, max_volume_drift, per_chain (per
/// chain: seed, acceptance, and {mean, error, inefficiency, blocking_converged} of each
/// observable).
nlohmann::json to_json(const McSummary& summary, const McRunSetup& setup);

/// The thread decision as JSON: {"used": threads, "requested": requested, "reason": reason}.
nlohmann::json to_json(const McThreadDecision& decision);

/// The run keys (no timing): vertices, force_pN, temperature_K, kT_pNum, seed, chains,
/// chain_seeds, streams, threads (to_json(McRun::thread_decision())), bending, penalty_scale,
/// colours, sweeps (the fewest of a chain), chain_sweeps, adaptive_sweeps, step_um (chain 0's),
/// chain_steps, reference_axial_um, reference_transverse_um, running_total_drift_area_um2,
/// running_total_drift_volume_um3 (largest over the chains); for HMC also "hmc":
/// {trajectory_time, evaluations, solves (totals over the chains of this process's run),
/// mass_matrix, mass_shift_pN_per_um, mass_reference (the option: equilibrium or thermal),
/// mass_built_at (chain 0's matrix in use: "start", or "thermal mean" after the thermal
/// rebuild), mass_reference_transitions (positions averaged for it), rigid_mass_pN_per_um,
/// factor_nonzeros}.
nlohmann::json mc_run_json(const Network& net, const McRun& run);
/// mc_run_json without the sampler-specific block.
nlohmann::json mc_run_keys(const Network& net, const McRun& run);

/// Text a caller adds to the files it writes: comment lines of the CSV files, text attributes of
/// the HDF5 files (e.g. what produced them: the rbc version, command line, configuration).
struct OutputRecord {
  std::vector<std::string> comment_lines;
  std::vector<std::pair<std::string, std::string>> attributes;
};

/// DIR/mc_series.csv and DIR/mc_series.h5 (/series, samples x 8, columns attribute) of chain 0,
/// and DIR/mc_series_chain<c>.csv / .h5 of each further chain c (same columns), atomic.
void write_mc_series(const std::string& dir, const McRun& run, const OutputRecord& record = {});

/// DIR/mc_snapshot_SSSSSSSS.h5/.xdmf of chain 0: positions, displacement_um (|x - X|, as the
/// stretch shapes), displacement_x_um (its x component), force, temperature, sweep.
void write_mc_snapshot(const std::string& dir, const Network& net, const McRun& run,
                       const OutputRecord& record = {});

}  // namespace rbc
