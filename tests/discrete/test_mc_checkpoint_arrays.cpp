// SPDX-License-Identifier: GPL-3.0-or-later
// The checks applied to a loaded checkpoint's arrays (discrete/mc_checkpoint_arrays.hpp): a
// checkpoint written from a real chain passes, and each way a file can lie is refused. The RNG
// check reads GSL's mt19937 state through its own copy of the layout, so that layout is tested
// here against GSL itself (state size, and the position word counting the draws).
#include <gsl/gsl_rng.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>

#include "discrete/mc_checkpoint_arrays.hpp"

namespace rbc {
namespace {

constexpr std::size_t kWords = 625;  // ceil(5000 / 8): 624 state words and the position mti

struct Rng {
  std::unique_ptr<gsl_rng, decltype(&gsl_rng_free)> r{gsl_rng_alloc(gsl_rng_mt19937),
                                                      &gsl_rng_free};
};

/// The packed state of one seeded stream after `draws` draws, as write_mc_checkpoint stores it.
std::vector<unsigned long long> packed_state(unsigned long seed, int draws) {
  Rng g;
  gsl_rng_set(g.r.get(), seed);
  for (int i = 0; i < draws; ++i) gsl_rng_get(g.r.get());
  std::vector<unsigned long long> w(kWords, 0ull);
  std::memcpy(w.data(), gsl_rng_state(g.r.get()), gsl_rng_size(g.r.get()));
  return w;
}

int mti_of(const std::vector<unsigned long long>& w, std::size_t stream = 0) {
  int mti = 0;
  std::memcpy(&mti, reinterpret_cast<const unsigned char*>(w.data() + stream * kWords) + 624 * 8,
              sizeof mti);
  return mti;
}

/// A valid 4-vertex, 2-stream checkpoint with 3 samples at sweeps 2, 4, 6 of 6.
McCheckpointArrays valid() {
  McCheckpointArrays a;
  a.vertices = 4;
  a.positions_um = {1, 0, 0, 0, 1, 0, 0, 0, 1, -1, -1, -1};
  a.positions_rows = 4;
  a.positions_cols = 3;
  a.rng_state = packed_state(7, 10);
  const auto second = packed_state(8, 700);  // past one regeneration of the 624 words
  a.rng_state.insert(a.rng_state.end(), second.begin(), second.end());
  a.rng_rows = 2;
  a.rng_cols = kWords;
  a.rng_bytes = 5000;
  a.streams = 2;
  for (int s = 1; s <= 3; ++s) {
    const double row[] = {2.0 * s, -1.5, 9.1, 6.2, 134.1, 94.1, 0.4, 0.01};
    a.series.insert(a.series.end(), row, row + 8);
  }
  a.series_rows = 3;
  a.series_cols = 8;
  a.series_count = 3;
  a.sweep = 6;
  a.sample_every = 2;
  a.mobile = {-1};
  return a;
}

void expect_refused(const McCheckpointArrays& a, const std::string& fragment) {
  try {
    check_mc_checkpoint_arrays(a);
    ADD_FAILURE() << "accepted; expected a refusal mentioning '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(McCheckpointArrays, TheMt19937LayoutIsGsls) {
  EXPECT_EQ(mt19937_state_bytes(), gsl_rng_mt19937->size);
  EXPECT_EQ(mti_of(packed_state(7, 0)), 624);  // seeding leaves the position at the end
  EXPECT_EQ(mti_of(packed_state(7, 10)), 10);  // the first draw regenerates, then counts
  EXPECT_EQ(mti_of(packed_state(7, 700)), 700 - 624);
}

TEST(McCheckpointArrays, AValidCheckpointPasses) {
  EXPECT_NO_THROW(check_mc_checkpoint_arrays(valid()));
  McCheckpointArrays a = valid();
  a.mobile = {3, 0, 2};
  EXPECT_NO_THROW(check_mc_checkpoint_arrays(a));
  a = valid();  // no samples yet: the 1-row placeholder (one sweep, sampled every 2)
  a.series.assign(8, 0.0);
  a.series_rows = 1;
  a.series_count = 0;
  a.sweep = 1;
  EXPECT_NO_THROW(check_mc_checkpoint_arrays(a));
}

TEST(McCheckpointArrays, ShapesThatDisagreeAreRefused) {
  McCheckpointArrays a = valid();
  a.positions_rows = 5;
  expect_refused(a, "positions");
  a = valid();
  a.positions_um.pop_back();
  expect_refused(a, "positions table");
  a = valid();
  a.rng_rows = 1 << 30;  // a huge count must not read past the buffer
  expect_refused(a, "RNG state table");
  a = valid();
  a.streams = 3;
  expect_refused(a, "stream count");
  a = valid();
  a.rng_bytes = 4992;
  expect_refused(a, "bytes");
  a = valid();
  a.series_count = 2;
  expect_refused(a, "time series has the wrong shape");
  a = valid();
  a.series_cols = 7;
  expect_refused(a, "time series");
}

TEST(McCheckpointArrays, ValuesThatCannotBeUsedAreRefused) {
  McCheckpointArrays a = valid();
  a.positions_um[4] = std::numeric_limits<double>::quiet_NaN();
  expect_refused(a, "not finite");
  a = valid();
  a.rng_state[kWords + 624] = 0xffffffffull;  // mti = -1: GSL would read mt[-1]
  expect_refused(a, "stream 1");
  a = valid();
  a.rng_state[624] = 625;
  expect_refused(a, "stream 0");
  a = valid();
  a.rng_state[17] = 1ull << 32;  // a 33-bit word: gsl_rng_uniform could return >= 1
  expect_refused(a, "stream 0");
  a = valid();
  std::fill(a.rng_state.begin(), a.rng_state.begin() + 624, 0ull);  // a generator of zeros
  expect_refused(a, "stream 0");
  a = valid();
  a.series[8] = 1e19;  // a sweep number beyond long long (and beyond the chain)
  expect_refused(a, "sweep numbers");
  a = valid();
  a.series[16] = 4;  // sweeps 2, 4, 4: not increasing
  expect_refused(a, "sweep numbers");
  a = valid();
  a.series[8] = 3.5;
  expect_refused(a, "sweep numbers");
  a = valid();
  a.series[13] = std::numeric_limits<double>::infinity();
  expect_refused(a, "not finite");
  a = valid();
  a.sweep = -1;
  expect_refused(a, "sweep count");
}

// The counts of a checkpoint agree with each other: a chain at sweep S sampled every k sweeps
// holds floor(S / k) samples, of sweeps k, 2k, ... A sweep count edited on its own (the
// checksum recomputed, so only this check can tell) is refused.
TEST(McCheckpointArrays, SweepCountMustAgreeWithTheStoredSeries) {
  McCheckpointArrays a = valid();
  a.sweep = 7;  // 3 samples every 2 sweeps: sweeps 6 and 7 both hold 3
  EXPECT_NO_THROW(check_mc_checkpoint_arrays(a));
  a.sweep = 1'000'000'000'000'000LL;  // 1e15
  expect_refused(a, "sweep count 1000000000000000 disagrees with the stored time series");
  a = valid();
  a.sweep = 8;  // would hold a 4th sample at sweep 8
  expect_refused(a, "8 sweeps record 4");
  a = valid();
  a.sweep = 5;  // the sample of sweep 6 cannot exist yet
  expect_refused(a, "disagrees");
  a = valid();
  a.sample_every = 3;  // samples at 3, 6 would be 2, and the rows say 2, 4, 6
  expect_refused(a, "disagrees");
  a = valid();
  a.sample_every = 0;
  expect_refused(a, "sample interval 0");
  a = valid();
  a.series[0] = 1;  // sweeps 1, 4, 6: the count agrees, the sweep numbers do not
  expect_refused(a, "row 1 is of sweep 1, expected 2");
  a = valid();
  a.series_count = a.series_rows = 0;
  a.series.assign(8, 0.0);
  a.series_rows = 1;
  a.sweep = 1;  // one sweep, sampled every 2: no sample yet
  EXPECT_NO_THROW(check_mc_checkpoint_arrays(a));
  a.sweep = 2;
  expect_refused(a, "disagrees");
  a = valid();
  a.mobile = {0, 4};
  expect_refused(a, "mobile");
  a = valid();
  a.mobile = {2, 2};
  expect_refused(a, "mobile");
  a = valid();
  a.mobile.clear();
  expect_refused(a, "mobile");
}

}  // namespace
}  // namespace rbc
