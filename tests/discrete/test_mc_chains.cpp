// SPDX-License-Identifier: GPL-3.0-or-later
// Independent chains of a Monte Carlo run (discrete/mc_run.hpp): results bit-identical for one
// and two threads (Metropolis and HMC), distinct chain seeds, pooled means and errors against
// the chains' own statistics and against a Boltzmann expectation computed by quadrature,
// split-R-hat near 1 for mixed chains and large for chains held apart, and checkpoints of every
// chain that resume bit for bit on another thread count, also after a cancel mid-block.
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <memory>
#include <set>

#include "core/h5file.hpp"
#include "core/rest_shape.hpp"
#include "core/units.hpp"
#include "discrete/mc_checkpoint.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/network_energy.hpp"
#include "discrete/stretch.hpp"
#include "fixtures.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

Network small_cell(int n) {
  RestShapeOptions o;
  o.target_vertices = n;
  return build_network(make_rest_shape(o), NetworkParameters{});
}

McRunSetup chains_setup(McAlgorithm algorithm, int threads) {
  McRunSetup s;
  s.force_pN = 20;
  s.sampler.algorithm = algorithm;
  s.sampler.temperature_K = 300;
  s.sampler.seed = 11;
  s.sampler.streams = 2;
  s.sampler.chains = 2;
  s.sampler.threads = threads;  // the chains' threads (McOptions::threads caps them)
  s.sampler.adapt_sweeps = 4;
  s.penalty_scale = 1.0;
  return s;
}

void expect_same_series(const std::vector<McSample>& a, const std::vector<McSample>& b,
                        const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].sweep, b[i].sweep) << what << " sample " << i;
    EXPECT_EQ(a[i].energy_pNum, b[i].energy_pNum) << what << " sample " << i;
    EXPECT_EQ(a[i].axial_um, b[i].axial_um) << what << " sample " << i;
    EXPECT_EQ(a[i].area_um2, b[i].area_um2) << what << " sample " << i;
    EXPECT_EQ(a[i].step_um, b[i].step_um) << what << " sample " << i;
  }
}

void expect_same_run(const McRun& a, const McRun& b) {
  ASSERT_EQ(a.chain_count(), b.chain_count());
  for (int c = 0; c < a.chain_count(); ++c) {
    expect_same_series(a.series(c), b.series(c), "chain " + std::to_string(c));
    EXPECT_EQ((a.chain(c).positions() - b.chain(c).positions()).cwiseAbs().maxCoeff(), 0.0) << c;
    EXPECT_EQ(a.chain(c).state().rng_state, b.chain(c).state().rng_state) << c;
  }
}

TEST(McChains, OptionsAreValidated) {
  const Network net = small_cell(150);
  for (int bad : {0, -1, kMaxMcChains + 1}) {
    McRunSetup s = chains_setup(McAlgorithm::metropolis, 0);
    s.sampler.chains = bad;
    EXPECT_THROW(s.validate(), std::invalid_argument) << bad;
    EXPECT_THROW(McRun(net, s, net.rest), std::invalid_argument) << bad;
  }
  // One chain state for a run of two chains is refused, not silently run as one chain.
  McRun run(net, chains_setup(McAlgorithm::metropolis, 1), net.rest);
  run.advance(2);
  EXPECT_THROW(McRun(net, run.setup(), run.state(), run.series()), std::invalid_argument);
  EXPECT_THROW(run.advance_blocks(4, 0), std::invalid_argument);
}

TEST(McChains, ChainSeedsAreDistinctAndChainZeroKeepsTheSeed) {
  for (unsigned long seed : {0ul, 1ul, 11ul, 4294967296ul, 18446744073709551615ul}) {
    EXPECT_EQ(mc_chain_seed(seed, 0), seed);
    std::set<unsigned long> low32;
    for (int c = 0; c < kMaxMcChains; ++c) low32.insert(mc_chain_seed(seed, c) & 0xffffffffu);
    EXPECT_EQ(low32.size(), std::size_t(kMaxMcChains)) << "seed " << seed;
  }
}

// The pooled results, and every chain, are bit-identical on one and two threads; the two
// chains (different seeds) differ from each other.
TEST(McChains, ResultsAreBitIdenticalForOneAndTwoThreadsAndChainsDiffer) {
  const Network net = small_cell(150);
  Positions start = net.rest;
  ConstraintMultipliers lambda;
  ASSERT_TRUE(solve_equilibrium(net, 20.0, start, lambda, StretchOptions{}).converged);
  for (McAlgorithm algorithm : {McAlgorithm::metropolis, McAlgorithm::hmc}) {
    SCOPED_TRACE(to_string(algorithm));
    McRunSetup one_thread = chains_setup(algorithm, 1), two_threads = chains_setup(algorithm, 2);
    one_thread.multipliers = two_threads.multipliers = lambda;
    McRun a(net, one_thread, start), b(net, two_threads, start);
    EXPECT_EQ(a.thread_decision().threads, 1);
    EXPECT_EQ(b.thread_decision().threads, 2);
    const long long sweeps = algorithm == McAlgorithm::hmc ? 24 : 40;
    a.advance(sweeps);
    b.advance_blocks(sweeps, 7);
    expect_same_run(a, b);
    const McSummary sa = a.summarise(), sb = b.summarise();
    EXPECT_EQ(sa.axial.mean, sb.axial.mean);
    EXPECT_EQ(sa.axial.error, sb.axial.error);
    EXPECT_EQ(sa.energy.mean, sb.energy.mean);
    EXPECT_EQ(sa.axial_check.rhat, sb.axial_check.rhat);
    // Chains of different seeds take different paths.
    ASSERT_EQ(a.series(0).size(), a.series(1).size());
    EXPECT_NE(a.series(0).back().energy_pNum, a.series(1).back().energy_pNum);
    EXPECT_GT((a.chain(0).positions() - a.chain(1).positions()).cwiseAbs().maxCoeff(), 0.0);
  }
}

// The pooled mean is the mean of the chain means and the pooled error combines the chains'
// errors, each recomputed here from the chain's own series.
TEST(McChains, PooledStatisticsCombineEveryChain) {
  const Network net = small_cell(150);
  McRunSetup setup = chains_setup(McAlgorithm::metropolis, 0);
  setup.sampler.chains = 3;
  McRun run(net, setup, net.rest);
  run.advance(80);
  const McSummary s = run.summarise();
  ASSERT_EQ(s.chains, 3);
  ASSERT_EQ(s.per_chain.size(), 3u);
  double mean = 0, err2 = 0;
  std::size_t samples = 0;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> d;
    for (const McSample& x : run.series(c))
      if (x.sweep > setup.sampler.adapt_sweeps) d.push_back(x.axial_um);
    d.erase(d.begin(), d.begin() + std::ptrdiff_t(s.discarded));
    const BlockingResult b = correlated_mean(d);
    EXPECT_EQ(b.mean, s.per_chain[std::size_t(c)].axial.mean) << c;
    EXPECT_EQ(s.per_chain[std::size_t(c)].seed, mc_chain_seed(setup.sampler.seed, c));
    mean += b.mean / 3;
    err2 += b.error * b.error;
    samples += d.size() + s.discarded;
  }
  EXPECT_NEAR(s.axial.mean, mean, 1e-12 * std::abs(mean));
  EXPECT_NEAR(s.axial.error, std::sqrt(err2) / 3, 1e-12 * s.axial.error);
  EXPECT_EQ(s.samples, samples);
  EXPECT_EQ(s.axial_check.chain_dof, 2);
  EXPECT_GT(s.axial_check.between_chain_error, 0.0);
}

// split_rhat on series of known character: independent normal draws of one law give R-hat
// within 1% of 1; chains whose means differ by one standard deviation, or one chain drifting,
// give R-hat far above the threshold.
TEST(McChains, SplitRhatSeparatesMixedFromUnmixedChains) {
  std::unique_ptr<gsl_rng, void (*)(gsl_rng*)> rng(gsl_rng_alloc(gsl_rng_mt19937), gsl_rng_free);
  gsl_rng_set(rng.get(), 5);
  const int n = 4000;
  std::vector<std::vector<double>> mixed(4, std::vector<double>(n)), apart = mixed;
  for (int c = 0; c < 4; ++c)
    for (int i = 0; i < n; ++i) {
      mixed[c][i] = gsl_ran_gaussian_ziggurat(rng.get(), 1.0);
      apart[c][i] = mixed[c][i] + (c % 2 ? 1.0 : 0.0);
    }
  // With 8 half-chains of 2,000 independent draws, R-hat - 1 is of order 1/n: 1.01 is far out.
  EXPECT_LT(split_rhat(mixed), 1.005);
  EXPECT_GT(split_rhat(mixed), 0.995);
  EXPECT_GT(split_rhat(apart), 1.1);
  std::vector<std::vector<double>> drift{std::vector<double>(n)};
  for (int i = 0; i < n; ++i) drift[0][i] = mixed[0][i] + 3.0 * i / n;  // one chain, a trend
  EXPECT_GT(split_rhat(drift), 1.1);
  EXPECT_EQ(split_rhat({std::vector<double>(8, 2.0)}), 1.0);
  EXPECT_THROW(split_rhat({std::vector<double>(3, 1.0)}), std::invalid_argument);
  EXPECT_THROW(split_rhat({std::vector<double>(8, 1.0), std::vector<double>(9, 1.0)}),
               std::invalid_argument);
}

/// One mobile vertex of a 42-vertex sphere at a temperature that gives it a thermal width of ~8 %
/// of a link (the fixture of McSampler.SingleVertexHistogramMatchesBoltzmannChiSquare): its
/// Boltzmann law is a 3-D integral, so <F> is known by quadrature.
struct OneVertexWell {
  Network net = build_network(testing::sphere_mesh(2, 1.0), NetworkParameters{});
  LoadState load;
  int v = 0;
  double kT = 0;
  Eigen::Matrix3d hess;
  double energy_at(const Eigen::Vector3d& y) const {
    Positions x = net.rest;
    x.col(v) = y;
    return network_energy(net, x, load);
  }
  OneVertexWell() {
    const double h = 1e-3;
    const Eigen::Vector3d x0 = net.rest.col(v);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const Eigen::Vector3d ei = h * Eigen::Vector3d::Unit(i), ej = h * Eigen::Vector3d::Unit(j);
        hess(i, j) = (energy_at(x0 + ei + ej) - energy_at(x0 + ei - ej) - energy_at(x0 - ei + ej) +
                      energy_at(x0 - ei - ej)) /
                     (4 * h * h);
      }
    const double kmax =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(hess).eigenvalues().maxCoeff();
    kT = kmax * std::pow(0.08 * net.lbar_um.mean(), 2);
  }
  /// <F> by midpoint quadrature over +-7 thermal widths of the harmonic well in its eigenframe
  /// (the weight beyond is below 1e-10; 56 points per axis resolve a width by 4).
  double mean_energy() const {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(hess);
    const Eigen::Vector3d half = 7.0 * (kT * eig.eigenvalues().cwiseInverse()).cwiseSqrt();
    const Eigen::Vector3d x0 = net.rest.col(v);
    const double e0 = energy_at(x0);
    const int g = 56;
    double z = 0, ez = 0;
    for (int i = 0; i < g; ++i)
      for (int j = 0; j < g; ++j)
        for (int k = 0; k < g; ++k) {
          const Eigen::Vector3d u((2.0 * (i + 0.5) / g - 1.0) * half(0),
                                  (2.0 * (j + 0.5) / g - 1.0) * half(1),
                                  (2.0 * (k + 0.5) / g - 1.0) * half(2));
          const double de = energy_at(x0 + eig.eigenvectors() * u) - e0;
          if (!std::isfinite(de)) continue;
          const double w = std::exp(-de / kT);
          z += w;
          ez += w * de;
        }
    return e0 + ez / z;
  }
};

// The pooled mean of the sampled energy of the one-vertex well agrees with its Boltzmann mean by
// quadrature within 3.5 pooled errors, the chains agree with each other (chi-square of the chain
// means against the pooled one, 3 degrees of freedom, above the 1e-3 tail) and R-hat is below
// the threshold. False alarms: 4.7e-4 for the mean (normal), 1e-3 for the chi-square.
TEST(McChains, PooledMeanOfAOneVertexWellMatchesQuadrature) {
  const OneVertexWell w;
  const double expected = w.mean_energy();
  McRunSetup setup;
  setup.sampler.temperature_K = w.kT / units::thermal_energy_pNum(1.0);
  setup.sampler.seed = 2024;
  setup.sampler.mobile = {w.v};
  setup.sampler.chains = 4;
  setup.sampler.adapt_sweeps = 2000;
  setup.penalty_scale = 1.0;  // the load of w.energy_at
  McRun run(w.net, setup, w.net.rest);
  run.advance_blocks(2000 + 30000, 2000);
  const McSummary s = run.summarise();
  const double kT = w.kT;
  EXPECT_NEAR(s.energy.mean, expected, 3.5 * s.energy.error)
      << "pooled <F> - quadrature = " << (s.energy.mean - expected) / kT << " kT, error "
      << s.energy.error / kT << " kT";
  // The error is converged (30,000 sweeps of a well with g ~ 20-40) and consistent with the
  // spread of the four chain means.
  EXPECT_TRUE(s.energy.converged);
  EXPECT_GT(s.energy_check.chain_p_value, 1e-3) << "chi2 " << s.energy_check.chain_chi2;
  EXPECT_LT(s.energy_check.rhat, kMcRhatThreshold);
  // Power: the mean energy of a chain at a 10 % higher temperature is 0.15 kT higher
  // (equipartition, 3/2 kT), > 7 pooled errors.
  EXPECT_LT(s.energy.error, 0.02 * kT);
}

// Chains held apart (one chain restarted with the vertex displaced by 0.03 um and a trial step of
// 1e-6 um that never adapts, so it cannot return within the run) give R-hat far above the
// threshold and the run is flagged as not converged.
TEST(McChains, ChainsHeldApartAreFlaggedByRhat) {
  const OneVertexWell w;
  McRunSetup setup;
  setup.sampler.temperature_K = w.kT / units::thermal_energy_pNum(1.0);
  setup.sampler.seed = 3;
  setup.sampler.mobile = {w.v};
  setup.sampler.chains = 2;
  setup.sampler.adapt_sweeps = 0;
  setup.sampler.initial_step_um = 1e-6;
  setup.penalty_scale = 1.0;
  McRun fresh(w.net, setup, w.net.rest);
  std::vector<McChainState> states = fresh.states();
  states[1].x(0, w.v) += 0.03;
  McRun apart(w.net, setup, states, {{}, {}});
  apart.advance(400);
  const McSummary s = apart.summarise();
  EXPECT_GT(s.energy_check.rhat, 1.5);
  EXPECT_FALSE(s.energy_check.converged);
  EXPECT_FALSE(s.converged);
  EXPECT_LT(s.energy_check.chain_p_value, 1e-6);
}

// A run of two chains checkpointed at a block end on two threads and resumed on one continues
// both chains bit for bit; so does a run cancelled in the middle of a block, whose chains may
// stand at different sweeps.
TEST(McChains, CheckpointOfEveryChainResumesBitForBitOnAnotherThreadCount) {
  const Network net = small_cell(150);
  const auto dir = rbc::testing::fresh_output_dir("mc_chains_checkpoint");
  for (McAlgorithm algorithm : {McAlgorithm::metropolis, McAlgorithm::hmc}) {
    SCOPED_TRACE(to_string(algorithm));
    McRunSetup setup = chains_setup(algorithm, 2);
    McRun whole(net, setup, net.rest);
    whole.advance(14);
    // Stopped after the block ending at sweep 6.
    McRun first(net, setup, net.rest);
    const std::string file = (dir / ("block_" + to_string(algorithm) + ".h5")).string();
    first.advance_blocks(14, 3, [&](const McRun& r) {
      if (r.sweeps_done() < 6) return true;
      write_mc_checkpoint(file, net, McCheckpoint::of(r, {14, -1.0}));
      return false;
    });
    McCheckpoint cp = read_mc_checkpoint(file, net);
    ASSERT_EQ(cp.chains.size(), 2u);
    EXPECT_EQ(cp.setup.sampler.chains, 2);
    EXPECT_EQ(cp.chains[1].sweep, 6);
    cp.setup.sampler.threads = 1;
    McRun resumed(net, cp.setup, cp.chains, cp.chain_series);
    EXPECT_EQ(resumed.thread_decision().threads, 1);
    resumed.advance(14);
    expect_same_run(whole, resumed);
    // Cancelled by the hook on its 4th poll, inside a block of 10 sweeps.
    McRunSetup cancelling = setup;
    int polls = 0;
    cancelling.cancel = [&] { return ++polls > 3; };
    McRun cancelled(net, cancelling, net.rest);
    EXPECT_THROW(cancelled.advance_blocks(14, 10), Cancelled);
    EXPECT_LT(cancelled.sweeps_done(), 14);
    const std::string cfile = (dir / ("cancel_" + to_string(algorithm) + ".h5")).string();
    write_mc_checkpoint(cfile, net, McCheckpoint::of(cancelled));
    McCheckpoint cc = read_mc_checkpoint(cfile, net);
    cc.setup.sampler.threads = 1;
    McRun continued(net, cc.setup, cc.chains, cc.chain_series);
    continued.advance(14);
    expect_same_run(whole, continued);
  }
}

// A checkpoint of the one-chain format (version 6) is refused with a message naming both
// versions.
TEST(McChains, CheckpointOfTheOneChainFormatIsRefused) {
  const Network net = small_cell(150);
  const auto dir = rbc::testing::fresh_output_dir("mc_chains_format6");
  const std::string old = (dir / "format6.h5").string();
  {
    H5File h = H5File::create(old);
    h.write_attribute("format", 6LL);
    h.write_attribute("vertices", static_cast<long long>(net.topo.num_vertices));
    h.write_attribute("bending_model", std::string("juelicher"));
  }
  try {
    read_mc_checkpoint(old, net);
    ADD_FAILURE() << "a format-6 checkpoint was accepted";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("format version 6"), std::string::npos) << m;
    EXPECT_NE(m.find("reads version 7"), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace rbc
