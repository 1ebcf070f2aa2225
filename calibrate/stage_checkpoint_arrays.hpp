// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The arrays of a stage checkpoint (calibrate/stage_checkpoint.hpp) as read from the file and
// not yet trusted, and the checks they must pass before a resumed run uses them. Kept apart
// from the HDF5 reader, on the standard library alone, so a fuzz target tests exactly these
// checks (fuzz/fuzz_infer_checkpoint.cpp).
//
// Layout (one table per dataset, rows x cols as stored):
//   theta            samples x dimension   the population
//   log_likelihood   samples x 1           finite or -infinity (a failed forward run)
//   state_index      samples x 1           entry of the warm-state pool of each sample
//   state_offsets    (entries + 1) x 1     entry e is state_values[offsets[e], offsets[e+1])
//   state_values     max(total, 1) x 1     the pool's values (one unused row when empty)
//   schedule         (stage + 1) x 1       tempering exponents, 0 first, increasing, <= 1
//   stage_log        (stage + 1) x 8       stage, beta, cov, log_mean_weight, acceptance,
//                                          distinct parents, forward runs (cumulative), elapsed_s
//   accumulators     name -> n x 1         the sampler's running sums
// and the forward-run counters.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace rbc {

/// A dataset as stored: its values (row-major) and shape.
template <class T>
struct CheckpointTable {
  std::vector<T> values;
  std::size_t rows = 0, cols = 0;
};

/// Columns of the stage log.
inline constexpr std::size_t kStageLogColumns = 8;

struct StageCheckpointArrays {
  std::string sampler;  ///< "tmcmc" (this layout; laplace-is has calibrate/laplace_is_checkpoint)
  long long stage = 0, samples = 0, dimension = 0;
  CheckpointTable<double> theta, log_likelihood;
  CheckpointTable<unsigned long long> state_index, state_offsets;
  CheckpointTable<double> state_values;
  CheckpointTable<double> schedule, stage_log;
  std::vector<std::pair<std::string, CheckpointTable<double>>> accumulators;
  long long runs = 0, retried = 0, failed = 0, symmetry_broken = 0;  ///< forward-run counters
};

/// Largest population, dimension and stage count a checkpoint may declare (far above any
/// real run; they bound the memory a corrupt file can make the reader allocate).
inline constexpr long long kMaxCheckpointSamples = 10000000, kMaxCheckpointDimension = 64,
                           kMaxCheckpointStages = 1000000;

/// Throws std::runtime_error naming the first inconsistency: shapes against the declared
/// samples, dimension and stage; values (finite theta, log-likelihoods finite or -infinity,
/// a schedule from 0 increasing to at most 1, the stage log agreeing with the schedule and the
/// counters, pool indices and offsets in range); the sampler's accumulators (TMCMC:
/// log_evidence_island finite or -infinity, delta_method_variance one finite value >= 0).
/// Accepted arrays are safe to index as the layout above says.
void check_stage_checkpoint_arrays(const StageCheckpointArrays& a);

}  // namespace rbc
