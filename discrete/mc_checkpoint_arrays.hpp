// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The checks applied to the arrays of a Monte Carlo checkpoint once they are read
// (discrete/mc_checkpoint.cpp), on plain buffers: nothing of it needs HDF5 or GSL, so the fuzz
// target fuzz/fuzz_mc_checkpoint.cpp links this one file. A checkpoint is outside input (a file
// may be truncated, overwritten or crafted); every array is checked before any of it is used.
#include <cstddef>
#include <string>
#include <vector>

namespace rbc {

/// Columns of the stored time series (kMcSampleColumns of discrete/mc_run.hpp; column 0 = sweep).
inline constexpr int kMcCheckpointSeriesColumns = 8;

/// The arrays and counts of a checkpoint as stored (row-major tables with their stored shapes).
struct McCheckpointArrays {
  long long vertices = 0;            ///< attribute `vertices` (N)
  std::vector<double> positions_um;  ///< /positions_um, N x 3, um
  std::size_t positions_rows = 0, positions_cols = 0;
  std::vector<unsigned long long> rng_state;  ///< /rng_state, streams x words (8 bytes each)
  std::size_t rng_rows = 0, rng_cols = 0;
  long long rng_bytes = 0;     ///< attribute `rng_bytes`: state bytes per stream
  long long streams = 0;       ///< attribute `streams`
  std::vector<double> series;  ///< /series, samples x 8 (1 x 8 zeros if none)
  std::size_t series_rows = 0, series_cols = 0;
  long long series_count = 0;  ///< attribute `series_rows` (recorded samples)
  long long sweep = 0;         ///< attribute `sweep`: completed sweeps
  long long sample_every = 1;  ///< attribute `sample_every`: sweeps between recorded samples
  std::vector<int> mobile;     ///< /mobile: vertex indices, or {-1} (all move)
};

/// State bytes of GSL's mt19937 as this check reads them: 624 `unsigned long` words (each
/// < 2^32) followed by the `int` position mti in [0, 624] (gsl/rng/mt.c, mt_state_t).
std::size_t mt19937_state_bytes();

/// Throws std::runtime_error saying what is wrong (the caller adds the file's name) unless:
/// N >= 1; positions N x 3 and finite; rng_bytes == mt19937_state_bytes(), the RNG table
/// `streams` x ceil(rng_bytes / 8) with streams >= 1 and each stream a valid mt19937 state (words
/// < 2^32, not all zero, mti in [0, 624]; GSL reads mt[mti] unchecked); sweep >= 0; the series
/// table has 8 columns and series_count rows (or the 1-row placeholder when 0) and finite
/// values; mobile is {-1} or distinct indices in [0, N). Every table's buffer holds exactly
/// rows x cols values. The counts agree with each other: a chain records a sample after every
/// sweep that is a multiple of sample_every (>= 1), so a chain at `sweep` holds
/// sweep / sample_every samples whose sweep numbers are sample_every, 2 sample_every, ...
/// (a sweep count edited on its own, e.g. to 1e15, is refused).
void check_mc_checkpoint_arrays(const McCheckpointArrays& a);

}  // namespace rbc
