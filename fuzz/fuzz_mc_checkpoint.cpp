// SPDX-License-Identifier: GPL-3.0-or-later
// Fuzz target: the checks applied to the arrays of a loaded Monte Carlo checkpoint
// (discrete/mc_checkpoint_arrays.cpp, check_mc_checkpoint_arrays) before rbc mc --resume uses
// them. The input bytes are decoded into the arrays and counts of a checkpoint; every byte 0
// means "as a valid checkpoint has it", so the empty input is a valid 4-vertex, 2-stream
// checkpoint and the fuzzer mutates from there (shapes, counts, values, RNG words, the sample
// interval against the sweep count and the series).
// The only allowed failure is std::runtime_error; an accepted set must be safe to use the way
// read_mc_checkpoint and GSL use it (asserted below with __builtin_trap).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

#include "discrete/mc_checkpoint_arrays.hpp"

namespace {

constexpr std::size_t kMaxBuffer = 1 << 14;  // values per table: bounds the memory of one input
constexpr std::size_t kMtWords = 624;

/// Reads the input byte by byte; 0 once it is exhausted.
struct Bytes {
  const std::uint8_t* p;
  std::size_t n;
  std::uint8_t next() {
    if (n == 0) return 0;
    --n;
    return *p++;
  }
};

/// A table dimension: `right` for 0, else a wrong small value or a huge one.
std::size_t dim(Bytes& in, std::size_t right) {
  const std::uint8_t b = in.next();
  if (b == 0) return right;
  if (b <= 200) return (b - 1) % (right + 4);
  return std::size_t(1) << (b - 201 + 8);
}

/// A buffer length for a rows x cols table: exact for 0, else off by a little.
std::size_t length(Bytes& in, std::size_t rows, std::size_t cols) {
  const bool fits = cols == 0 || rows <= kMaxBuffer / cols;
  const std::size_t right = fits ? rows * cols : kMaxBuffer;
  const std::uint8_t b = in.next();
  if (b == 0 || !fits) return right;
  const std::size_t off = b % 3;  // right - 1 or right + 1 (or right)
  return b & 1 ? right + off : (right >= off ? right - off : 0);
}

double special(std::uint8_t b, double normal) {
  switch (b) {
    case 0:
      return normal;
    case 1:
      return std::numeric_limits<double>::quiet_NaN();
    case 2:
      return std::numeric_limits<double>::infinity();
    case 3:
      return -std::numeric_limits<double>::infinity();
    case 4:
      return 1e308;
    case 5:
      return -1;
    case 6:
      return 1e19;  // a sweep number beyond long long
    case 7:
      return normal + 0.5;
    default:
      return (double(b) - 128.0) * 0.25;
  }
}

rbc::McCheckpointArrays decode(Bytes& in) {
  rbc::McCheckpointArrays a;
  std::uint8_t b = in.next();
  a.vertices = b == 0 ? 4 : static_cast<long long>(b % 12) - 2;
  const std::size_t n = a.vertices > 0 ? std::size_t(a.vertices) : 0;
  a.positions_rows = dim(in, n);
  a.positions_cols = dim(in, 3);
  a.positions_um.resize(length(in, a.positions_rows, a.positions_cols));
  for (std::size_t i = 0; i < a.positions_um.size(); ++i)
    a.positions_um[i] = special(i < 64 ? in.next() : 0, 0.1 * double(i % 7) - 0.3);

  static const long long rng_bytes[] = {0, 4992, 4996, 5004, 5008, 8, -1, 1LL << 40};
  b = in.next();
  a.rng_bytes = b == 0 ? static_cast<long long>(rbc::mt19937_state_bytes()) : rng_bytes[b % 8];
  b = in.next();
  a.streams = b == 0 ? 2 : static_cast<long long>(b % 6) - 1;
  const std::size_t words = (rbc::mt19937_state_bytes() + 7) / 8;
  a.rng_rows = dim(in, a.streams > 0 ? std::size_t(a.streams) : 0);
  a.rng_cols = dim(in, words);
  a.rng_state.resize(length(in, a.rng_rows, a.rng_cols));
  std::uint64_t h = 0x9e3779b97f4a7c15ull;  // a valid-looking state: 32-bit words, mti = 624
  for (std::size_t i = 0; i < a.rng_state.size(); ++i) {
    h ^= h >> 29;
    h *= 0xbf58476d1ce4e5b9ull;
    a.rng_state[i] = a.rng_cols && i % a.rng_cols == kMtWords ? kMtWords : (h >> 32) | 1;
  }
  static const unsigned long long patch[] = {0,
                                             0xffffffffull,
                                             0x100000000ull,
                                             0xffffffffull /* mti -1 */,
                                             625,
                                             623,
                                             0x80000000ull /* mti INT_MIN */,
                                             ~0ull};
  for (int k = in.next() % 8; k > 0 && !a.rng_state.empty(); --k) {
    const std::size_t at = (std::size_t(in.next()) << 8 | in.next()) % a.rng_state.size();
    b = in.next();
    a.rng_state[at] = b < 8 ? patch[b] : 0;
    if (b == 8) {  // zero the whole stream
      const std::size_t cols = std::max<std::size_t>(a.rng_cols, 1), row0 = at - at % cols;
      std::fill(a.rng_state.begin() + long(row0),
                a.rng_state.begin() + long(std::min(row0 + cols, a.rng_state.size())), 0ull);
    }
  }

  b = in.next();
  a.sweep = b == 0 ? 10 : static_cast<long long>(b % 14) - 2;
  b = in.next();
  a.series_count = b == 0 ? 3 : static_cast<long long>(b % 7) - 1;
  a.series_rows = dim(in, std::size_t(std::max(a.series_count, 1LL)));
  a.series_cols = dim(in, rbc::kMcCheckpointSeriesColumns);
  a.series.resize(length(in, a.series_rows, a.series_cols));
  for (std::size_t i = 0; i < a.series.size(); ++i) {
    const std::size_t cols = std::max<std::size_t>(a.series_cols, 1), row = i / cols;
    const double normal = i % cols == 0 ? 3.0 * double(row + 1) : 0.5;
    a.series[i] = special(i < 64 ? in.next() : 0, a.series_count > 0 ? normal : 0.0);
  }

  b = in.next();
  if (b == 0) {
    a.mobile = {-1};
  } else {
    for (int k = b % 6; k > 0; --k) a.mobile.push_back(int(in.next() % 13) - 3);
  }
  // Last, so the older corpus files keep their meaning: the sample interval (3 by default, which
  // the default series' sweeps 3, 6, 9 of 10 agree with), else a wrong small or a huge one.
  b = in.next();
  static const long long every[] = {1, 2, 4, 5, 0, -1, 1LL << 40, 9223372036854775807LL};
  a.sample_every = b == 0 ? 3 : every[b % 8];
  return a;
}

/// What read_mc_checkpoint and GSL do with accepted arrays must be safe.
void use(const rbc::McCheckpointArrays& a) {
  const std::size_t n = std::size_t(a.vertices);
  if (a.positions_um.size() != 3 * n) __builtin_trap();
  for (double v : a.positions_um)
    if (!std::isfinite(v)) __builtin_trap();
  const std::size_t words = a.rng_cols;
  if (a.rng_bytes <= 0 || std::size_t(a.rng_bytes) > 8 * words) __builtin_trap();
  if (a.rng_rows != std::size_t(a.streams) || a.rng_state.size() != a.rng_rows * words)
    __builtin_trap();
  for (std::size_t s = 0; s < a.rng_rows; ++s) {
    const unsigned long long* w = a.rng_state.data() + s * words;
    int mti = 0;
    std::memcpy(&mti, reinterpret_cast<const unsigned char*>(w) + kMtWords * 8, sizeof mti);
    if (mti < 0 || std::size_t(mti) > kMtWords) __builtin_trap();  // GSL reads mt[mti]
    for (std::size_t i = 0; i < kMtWords; ++i)
      if (w[i] > 0xffffffffull) __builtin_trap();  // gsl_rng_uniform would reach >= 1
  }
  if (a.series_cols != std::size_t(rbc::kMcCheckpointSeriesColumns)) __builtin_trap();
  // The counts agree: sweep / sample_every samples, of sweeps sample_every, 2 sample_every, ...
  if (a.sample_every < 1 || a.series_count != a.sweep / a.sample_every) __builtin_trap();
  for (long long i = 0; i < a.series_count; ++i) {
    const double* row = a.series.data() + i * a.series_cols;  // in bounds, else ASan reports
    const long long sweep = std::llround(row[0]);
    if (sweep < 0 || sweep > a.sweep || sweep != (i + 1) * a.sample_every) __builtin_trap();
    for (std::size_t c = 0; c < a.series_cols; ++c)
      if (!std::isfinite(row[c])) __builtin_trap();
  }
  for (int v : a.mobile)
    if (!(a.mobile.size() == 1 && v == -1) && (v < 0 || v >= a.vertices)) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in{data, size};
  const rbc::McCheckpointArrays a = decode(in);
  try {
    rbc::check_mc_checkpoint_arrays(a);
  } catch (const std::runtime_error&) {
    return 0;
  }
  use(a);
  return 0;
}
