// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Checkpoints of `rbc infer --sampler laplace-is` (calibrate/laplace_is.hpp): the run's state
// (LaplaceIsState) goes to OUT/checkpoint.h5 (kStageCheckpointName) after the first gradient
// evaluation, after every Newton step of the mode search, when the mode is found and after
// every block of importance draws, written to a temporary sibling and renamed into place as
// the stage checkpoint is (calibrate/stage_checkpoint.hpp), so the file always holds the last
// complete step. `rbc infer --sampler laplace-is --resume OUT` continues from it to the result
// of a straight run, bit for bit, on any number of threads.
//
// The file: HDF5, sealed, format kStageCheckpointFormat, root attribute `sampler`
// "laplace-is" (a TMCMC checkpoint says "tmcmc"; each sampler refuses the other's), the
// inputs, fingerprint and content checksum of the stage checkpoint (write_checkpoint_inputs,
// write_checkpoint_checksum), and
//   attributes  mode_found (0/1), newton_steps, gradient_evaluations, draws_done, samples,
//               dimension, state_size (values of the mode's warm state), forward_runs,
//               forward_retried, forward_failed, forward_symmetry_broken (of the draws),
//               mode_forward_runs, sensitivity_solves, recovery_trajectories (the mode
//               search's work so far, for the summary)
//   /mode/z            dimension x 1          the search's current point (logit coordinates)
//   /mode/point        (2 + dimension) x 1    log L, then the gradient d log L / d theta
//   /mode/information  dimension x dimension  Gauss-Newton information (row-major)
//   /mode/state        max(state_size, 1) x 1 the point's warm state
//   /draws/log_likelihood  max(draws_done, 1) x 1   of the draws evaluated (first draws_done)
//   /draws/state_offsets   (draws_done + 1) x 1     draw i's state: values [offsets[i], [i+1])
//   /draws/state_values    max(total, 1) x 1
// The inputs are those of the stage checkpoint without TMCMC's own options, with
// `--is-samples`.
#include <string>
#include <vector>

#include "calibrate/laplace_is.hpp"
#include "calibrate/stage_checkpoint.hpp"

namespace rbc {

/// What a laplace-is checkpoint holds.
struct LaplaceIsCheckpoint {
  std::vector<PosteriorInput> inputs;
  LaplaceIsState state;
  /// The mode search's work so far, counted by the caller (calibrate/laplace_is_infer.cpp):
  /// forward runs, sensitivity solves, release trajectories of recovery data.
  long long mode_forward_runs = 0, sensitivity_solves = 0, recovery_trajectories = 0;
};

/// The sampler name a laplace-is checkpoint carries ("laplace-is").
inline constexpr const char* kLaplaceIsSamplerName = "laplace-is";

/// The inputs that determine a laplace-is posterior: posterior_inputs(problem) without the
/// TMCMC options (--samples, --chain-length, --target-cov, --proposal-scale, islands, max
/// stages, max failure fraction), with `--is-samples`.
std::vector<PosteriorInput> laplace_is_inputs(const InferenceProblem& problem);

/// Writes the checkpoint atomically (temporary sibling, then rename). Throws
/// std::runtime_error naming the file.
void write_laplace_is_checkpoint(const std::string& path, const LaplaceIsCheckpoint& checkpoint,
                                 int samples);

/// Reads and checks a checkpoint: seal, format, sampler, content checksum, fingerprint, the
/// shapes and values (finite point, log-likelihoods finite or -infinity, offsets in range).
/// Throws std::runtime_error "checkpoint 'PATH' ..." naming what is wrong.
LaplaceIsCheckpoint read_laplace_is_checkpoint(const std::string& path);

/// read_laplace_is_checkpoint, then the checks against the problem: the same inputs
/// (check_posterior_inputs; `what` starts the message), the dimension, the samples and every
/// warm state the forward model's size. Throws std::runtime_error (a bad file) or
/// std::invalid_argument (another problem's file).
LaplaceIsCheckpoint load_laplace_is_checkpoint(const std::string& path,
                                               const InferenceProblem& problem,
                                               const std::string& what);

/// One line on where a checkpoint's run is: "mode search, after Newton step 3" or
/// "importance sampling, 20 of 40 draws evaluated" (or "mode found, ...").
std::string laplace_is_position(const LaplaceIsState& state, int samples);

}  // namespace rbc
