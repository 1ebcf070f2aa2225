// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Stage checkpoints of `rbc infer`: after every completed stage the sampler's state
// (tmcmc.hpp, SamplerState) goes to OUT/checkpoint.h5, written to a temporary sibling and
// renamed into place, so the file always holds the last complete stage (a run killed by
// SIGKILL during a stage or during the write leaves the previous one). `rbc infer --resume OUT`
// continues from it to the posterior a straight run gives, bit for bit, on any number of
// threads or MPI ranks.
//
// The file (HDF5, format kStageCheckpointFormat) names no sampler internals beyond
// "population + schedule + accumulators": root attributes `format`, `sampler` ("tmcmc"),
// `stage`, `samples`, `dimension`, the forward-run counters (`forward_runs`,
// `forward_retried`, `forward_failed`, `forward_symmetry_broken`), the inputs that determine
// the posterior (`inputs`: their names, one a line; `input NAME`: each value as text;
// `fingerprint`: FNV-1a of them all) and `content_checksum` (H5File::content_checksum of
// everything else, so a changed byte is refused, never resumed); datasets /population/theta,
// /population/log_likelihood, /population/state_index, /population/state_offsets,
// /population/state_values (warm states, each distinct one stored once), /schedule/exponent,
// /schedule/stage_log and /accumulators/NAME (listed in the attribute `accumulators`).
// calibrate/stage_checkpoint_arrays.hpp holds the shapes and the checks. Other inputs add
// `input NAME` entries. laplace-is writes its own layout into the same file name, with
// `sampler` "laplace-is" and the same inputs, fingerprint and checksum
// (calibrate/laplace_is_checkpoint.hpp); each sampler refuses the other's file.
#include <cstdint>
#include <string>
#include <vector>

#include "calibrate/tmcmc.hpp"

namespace rbc {

class InferenceProblem;
class H5File;

/// Format version of the stage checkpoint (a reader refuses any other).
inline constexpr long long kStageCheckpointFormat = 1;
/// The checkpoint's file name inside a run's output directory.
inline constexpr const char* kStageCheckpointName = "checkpoint.h5";

/// One input that determines the posterior: the option that sets it and its value as text.
struct PosteriorInput {
  std::string name, value;
  bool operator==(const PosteriorInput&) const = default;
};

/// The inputs of an inference that determine its posterior: the data files' contents (FNV-1a
/// of their bytes, declarations included; several files: every file, in order, with its stem
/// and its added extra uncertainty), the added extra uncertainty, the per-experiment
/// parameters, the method and
/// forward-solver options, the parameters, their prior boxes and the fixed parameters, the sampler
/// options and the seed. Never the threads or ranks, the data file's path or the output directory.
std::vector<PosteriorInput> posterior_inputs(const InferenceProblem& problem);

/// "fnv1a-64 HEX, N bytes": the FNV-1a hash of a data file's bytes and its size. Throws
/// std::runtime_error naming the file when it cannot be read.
std::string data_file_digest(const std::string& path);

/// FNV-1a of the inputs' names and values.
std::uint64_t posterior_fingerprint(const std::vector<PosteriorInput>& inputs);

/// What a checkpoint file holds.
struct StageCheckpoint {
  std::vector<PosteriorInput> inputs;
  SamplerState state;
};

/// Writes the checkpoint atomically (temporary sibling, then rename; the temporary is removed
/// on failure). Throws std::runtime_error naming the file.
void write_stage_checkpoint(const std::string& path, const std::vector<PosteriorInput>& inputs,
                            const SamplerState& state);

/// Reads a checkpoint and checks it: format version, content checksum, fingerprint and the
/// arrays (stage_checkpoint_arrays.hpp). Throws std::runtime_error "checkpoint 'PATH' ..."
/// naming what is wrong (missing, not HDF5, another format, corrupt).
StageCheckpoint read_stage_checkpoint(const std::string& path);

/// The pieces every checkpoint file shares (the stage checkpoint's and laplace-is's,
/// calibrate/laplace_is_checkpoint.hpp), on an open file: the inputs (attributes `inputs`,
/// `input NAME`, `fingerprint`) and the content checksum (attribute `content_checksum`, written
/// last, over everything else).
void write_checkpoint_inputs(H5File& file, const std::vector<PosteriorInput>& inputs);
/// Throws std::runtime_error "the fingerprint does not match ..." (no file name).
std::vector<PosteriorInput> read_checkpoint_inputs(const H5File& file);
void write_checkpoint_checksum(H5File& file);
/// Throws std::runtime_error "its contents do not match the checksum ..." (no file name).
void check_checkpoint_checksum(const H5File& file);

/// The `sampler` attribute of a checkpoint ("tmcmc", "laplace-is"), read from a sealed file.
/// Throws std::runtime_error "checkpoint 'PATH' cannot be read: ..." naming what is wrong.
std::string checkpoint_sampler(const std::string& path);

/// Throws std::invalid_argument "<what>: the checkpoint was written for NAME VALUE, this run
/// has NAME VALUE; ..." naming every input that differs (or is missing on either side).
void check_posterior_inputs(const std::vector<PosteriorInput>& stored,
                            const std::vector<PosteriorInput>& current, const std::string& what);

/// read_stage_checkpoint, then the checks against the problem: the same posterior inputs
/// (check_posterior_inputs; `what` starts the message, e.g. "--resume DIR"), the population's
/// shape, every sample inside the prior box and every warm state the forward model's size.
/// Throws std::runtime_error (a bad file) or std::invalid_argument (another problem's file).
SamplerState load_stage_checkpoint(const std::string& path, const InferenceProblem& problem,
                                   const std::string& what);

}  // namespace rbc
