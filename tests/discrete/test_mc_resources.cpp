// SPDX-License-Identifier: GPL-3.0-or-later
// Reliability of Monte Carlo runs: cancellation through the cancel hook stops at a sweep
// boundary from which the chain resumes bit for bit; resources are owned (a constructor that
// throws after allocating its RNG streams leaks nothing, checked by the sanitizer job's
// LeakSanitizer); old checkpoint formats are refused by name; the zero-temperature start-up
// continuation is bounded.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/h5file.hpp"
#include "core/rest_shape.hpp"
#include "discrete/mc_checkpoint.hpp"
#include "discrete/mc_run.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;

Network resources_network(int n) {
  RestShapeOptions o;
  o.target_vertices = n;
  return build_network(make_rest_shape(o), NetworkParameters{});
}

McRunSetup resources_setup() {
  McRunSetup s;
  s.force_pN = 20;
  s.sampler.temperature_K = 300;
  s.sampler.seed = 7;
  s.sampler.streams = 2;
  s.sampler.chains = 1;  // one chain (tests/discrete/test_mc_chains.cpp: several)
  s.sampler.adapt_sweeps = 4;
  return s;
}

fs::path fresh(const std::string& name) {
  const fs::path dir = fs::path(RBC_BINARY_DIR) / "test_output" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(McReliability, CancelStopsAtASweepBoundaryAndTheChainResumesBitForBit) {
  const Network net = resources_network(150);
  McRun whole(net, resources_setup(), net.rest);
  whole.advance(12);

  McRunSetup setup = resources_setup();
  int polls = 0;
  setup.cancel = [&] { return ++polls > 7; };  // "a signal" after 7 completed sweeps
  McRun cancelled(net, setup, net.rest);
  EXPECT_THROW(cancelled.advance(12), Cancelled);
  ASSERT_EQ(cancelled.sampler().sweeps_done(), 7);
  ASSERT_EQ(cancelled.series().size(), 7u);  // the series ends at the same sweep

  const fs::path dir = fresh("mc_reliability_cancel");
  const std::string file = (dir / "final.h5").string();
  write_mc_checkpoint(file, net,
                      McCheckpoint{cancelled.setup(), cancelled.state(), cancelled.series()});
  const McCheckpoint cp = read_mc_checkpoint(file, net);
  McRun resumed(net, cp.setup, cp.chain, cp.series);  // cp.setup has no cancel hook
  resumed.advance(12);
  EXPECT_EQ((resumed.state().x - whole.state().x).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(resumed.state().rng_state, whole.state().rng_state);
  ASSERT_EQ(resumed.series().size(), whole.series().size());
  for (std::size_t i = 0; i < whole.series().size(); ++i)
    EXPECT_EQ(resumed.series()[i].energy_pNum, whole.series()[i].energy_pNum) << i;
  EXPECT_GT((whole.state().x - net.rest).cwiseAbs().maxCoeff(), 0.0);
}

TEST(McReliability, ConstructorThatThrowsAfterAllocatingItsStreamsLeavesTheirOwnershipClean) {
  // restore() refuses the state after the constructor allocated the GSL streams, which are
  // owned by unique_ptrs: a raw gsl_rng* would leak ~10 kB per refusal. A leak itself is seen
  // by the ASan/LSan job; here: the refusal is an invalid_argument each time.
  const Network net = resources_network(150);
  McRun run(net, resources_setup(), net.rest);
  run.advance(2);
  McChainState bad = run.state();
  bad.rng_state[0].resize(7);  // a corrupt RNG state
  for (int k = 0; k < 50; ++k)
    EXPECT_THROW(McRun(net, resources_setup(), bad, run.series()), std::invalid_argument);
  McChainState infeasible = run.state();
  infeasible.x *= 4.0;  // links past Lmax (Lmax/Lbar = 3.17)
  EXPECT_THROW(McRun(net, resources_setup(), infeasible, run.series()), std::invalid_argument);
}

TEST(McReliability, CheckpointOfAnOlderFormatIsRefusedNamingTheVersion) {
  const Network net = resources_network(150);
  const fs::path dir = fresh("mc_reliability_format");
  const std::string old = (dir / "format2.h5").string();
  {
    H5File h = H5File::create(old);
    h.write_attribute("format", 2LL);
    h.write_attribute("vertices", static_cast<long long>(net.topo.num_vertices));
    h.write_attribute("bending_model", std::string("juelicher"));
  }
  for (auto read : {+[](const std::string&p, const Network&n) { read_mc_checkpoint(p, n); },
                    +[](const std::string&p, const Network&) { peek_mc_checkpoint_network(p); }}) {
    try {
      read(old, net);
      ADD_FAILURE() << "a format-2 checkpoint was accepted";
    } catch (const std::runtime_error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("format version 2"), std::string::npos) << m;
      EXPECT_NE(m.find("reads version 7"), std::string::npos) << m;  // the current format
      EXPECT_NE(m.find(old), std::string::npos) << m;
    }
  }
}

TEST(McReliability, CheckpointKeepsTheAdaptationScheduleItCameFrom) {
  const Network net = resources_network(150);
  const fs::path dir = fresh("mc_reliability_schedule");
  McRun run(net, resources_setup(), net.rest);
  run.advance(3);
  const std::string file = (dir / "c.h5").string();
  write_mc_checkpoint(file, net, McCheckpoint{run.setup(), run.state(), run.series(), {20, 0.2}});
  const McCheckpoint cp = read_mc_checkpoint(file, net);
  EXPECT_EQ(cp.schedule.planned_sweeps, 20);
  EXPECT_EQ(cp.schedule.adapt_fraction, 0.2);
  EXPECT_EQ(cp.setup.sampler.adapt_sweeps, 4);  // the absolute length, as run
}

TEST(McReliability, StartupContinuationIsBoundedAndEquallySpacedUpTo200pN) {
  // Up to 200 pN: ceil(F/40) equal steps, F k / n exactly.
  for (double f : {0.0, 16.0, 38.0, 88.0, 193.0, 200.0}) {
    const std::vector<double> s = mc_startup_forces(f);
    const int n = std::max(1, static_cast<int>(std::ceil(f / 40.0)));
    ASSERT_EQ(static_cast<int>(s.size()), n) << f;
    for (int k = 1; k <= n; ++k) EXPECT_EQ(s[k - 1], f * k / n) << f;
  }
  // Above: increasing, increments <= 20 % of the force reached, ends at F, count ~ log F.
  for (double f : {250.0, 1000.0, 1e4, 1e6, 1e12}) {
    const std::vector<double> s = mc_startup_forces(f);
    EXPECT_EQ(s.back(), f);
    for (std::size_t k = 1; k < s.size(); ++k) {
      EXPECT_GT(s[k], s[k - 1]);
      if (s[k - 1] >= 200.0) {
        EXPECT_LE(s[k] / s[k - 1], 1.2 * (1 + 1e-12)) << f;
      } else {
        EXPECT_LE(s[k] - s[k - 1], 40.0 * (1 + 1e-12)) << f;
      }
    }
    EXPECT_LE(s.size(), 5 + std::ceil(std::log(f / 200.0) / std::log(1.2))) << f;
  }
  // 1e6 pN: the 5 linear steps to 200 pN, then the fewest geometric steps of ratio <= 1.2 from
  // 200 pN to 1e6 pN, ceil(ln(1e6 / 200) / ln 1.2) = ceil(8.517 / 0.18232) = ceil(46.71) = 47:
  // 52 in all (a step of 40 pN throughout would take 25,000).
  EXPECT_EQ(mc_startup_forces(1e6).size(), 52u);
  EXPECT_THROW(mc_startup_forces(std::nan("")), std::invalid_argument);
  EXPECT_THROW(mc_startup_forces(-1.0), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
