// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/mc_checkpoint_arrays.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace rbc {

namespace {

// The layout of GSL's mt19937 state (gsl/rng/mt.c). Only read here, never written.
constexpr int kMtWords = 624;
struct Mt19937State {
  unsigned long mt[kMtWords];
  int mti;
};

constexpr int kSeriesColumns = kMcCheckpointSeriesColumns;

/// A stored value for a message ("1e+15", "12", "nan").
std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

[[noreturn]] void corrupt(const std::string& what) {
  throw std::runtime_error(what);
}

void check_shape(const char* name, std::size_t size, std::size_t rows, std::size_t cols) {
  if (cols != 0 && rows > size / cols) corrupt(std::string(name) + " table is truncated");
  if (size != rows * cols) corrupt(std::string(name) + " table has the wrong number of values");
}

}  // namespace

std::size_t mt19937_state_bytes() {
  return sizeof(Mt19937State);
}

void check_mc_checkpoint_arrays(const McCheckpointArrays& a) {
  if (a.vertices < 1) corrupt("vertex count " + std::to_string(a.vertices) + " is not >= 1");
  check_shape("positions", a.positions_um.size(), a.positions_rows, a.positions_cols);
  if (a.positions_rows != std::size_t(a.vertices) || a.positions_cols != 3)
    corrupt("positions have the wrong shape");
  for (double v : a.positions_um)
    if (!std::isfinite(v)) corrupt("positions are not finite");

  if (a.rng_bytes != static_cast<long long>(mt19937_state_bytes()))
    corrupt("RNG state has " + std::to_string(a.rng_bytes) + " bytes, mt19937 needs " +
            std::to_string(mt19937_state_bytes()));
  const std::size_t words = (mt19937_state_bytes() + 7) / 8;
  check_shape("RNG state", a.rng_state.size(), a.rng_rows, a.rng_cols);
  if (a.rng_cols != words || a.rng_rows < 1) corrupt("RNG state has the wrong shape");
  if (a.streams < 1 || a.rng_rows != std::size_t(a.streams))
    corrupt("RNG stream count differs from streams");
  for (std::size_t s = 0; s < a.rng_rows; ++s) {
    Mt19937State st;
    std::memcpy(&st, a.rng_state.data() + s * words, sizeof st);
    const bool zero = std::all_of(st.mt, st.mt + kMtWords, [](unsigned long w) { return w == 0; });
    const bool wide =
        std::any_of(st.mt, st.mt + kMtWords, [](unsigned long w) { return w > 0xffffffffUL; });
    if (zero || wide || st.mti < 0 || st.mti > kMtWords)
      corrupt("RNG state of stream " + std::to_string(s) + " is not a valid mt19937 state");
  }

  if (a.sweep < 0) corrupt("sweep count " + std::to_string(a.sweep) + " is negative");
  if (a.sample_every < 1)
    corrupt("sample interval " + std::to_string(a.sample_every) + " is not >= 1 sweep");
  check_shape("time series", a.series.size(), a.series_rows, a.series_cols);
  if (a.series_cols != std::size_t(kSeriesColumns) || a.series_count < 0 ||
      a.series_rows != std::size_t(std::max(a.series_count, 1LL)))
    corrupt("time series has the wrong shape");
  // One sample after every sweep that is a multiple of sample_every.
  const long long expected_samples = a.sweep / a.sample_every;
  if (a.series_count != expected_samples)
    corrupt("sweep count " + std::to_string(a.sweep) +
            " disagrees with the stored time series: " + std::to_string(a.series_count) +
            " samples, one every " + std::to_string(a.sample_every) + " sweeps, where " +
            std::to_string(a.sweep) + " sweeps record " + std::to_string(expected_samples));
  for (long long i = 0; i < a.series_count; ++i) {
    const double* row = a.series.data() + i * kSeriesColumns;
    for (int c = 0; c < kSeriesColumns; ++c)
      if (!std::isfinite(row[c])) corrupt("time series value is not finite");
    // (i + 1) sample_every <= series_count sample_every <= sweep: no overflow.
    const long long expected_sweep = (i + 1) * a.sample_every;
    if (row[0] != double(expected_sweep))
      corrupt("time series sweep numbers are not the multiples of the sample interval: row " +
              std::to_string(i + 1) + " is of sweep " + number(row[0]) + ", expected " +
              std::to_string(expected_sweep) + " (one sample every " +
              std::to_string(a.sample_every) + " sweeps)");
  }

  if (a.mobile.empty()) corrupt("mobile vertex list is empty");
  if (!(a.mobile.size() == 1 && a.mobile[0] == -1)) {
    std::vector<int> m = a.mobile;
    std::sort(m.begin(), m.end());
    if (m.front() < 0 || m.back() >= a.vertices ||
        std::adjacent_find(m.begin(), m.end()) != m.end())
      corrupt("mobile vertices are not distinct indices in [0, " + std::to_string(a.vertices) +
              ")");
  }
}

}  // namespace rbc
