// SPDX-License-Identifier: GPL-3.0-or-later
// The thermal mass reference of the collective sampler (HmcMassReference::thermal): the mass
// matrix is rebuilt once, at the mean of the positions over the second half of the adaptive
// phase, and fixed afterwards; the law sampled is the equilibrium reference's; a checkpoint
// inside the averaging window or after the rebuild resumes bit for bit, on any thread count.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <string>
#include <vector>

#include "discrete/hmc_sampler.hpp"
#include "discrete/mc_checkpoint.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/mc_workflow.hpp"
#include "discrete_cell_fixture.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

using testing::SmallCell;

McOptions thermal_mass_options(int adapt) {
  McOptions o;
  o.algorithm = McAlgorithm::hmc;
  o.temperature_K = 300;
  o.seed = 5;
  o.adapt_sweeps = adapt;
  o.hmc.mass_reference = HmcMassReference::thermal;
  return o;
}

// The reference is the start until the end of the adaptive phase, then exactly the mean of the
// positions after transitions floor(a/2) .. a-1 (summed here independently, in the same order),
// and it stays there: a sampler that rebuilt M again later (e.g. every few production
// transitions) or averaged another window fails.
TEST(HmcThermalMass, RebuiltOnceAtTheWindowMeanThenFixed) {
  const SmallCell c;
  const int adapt = 9;  // window: transitions 4 .. 8 (five positions)
  HmcSampler h(c.net, c.load, c.x, thermal_mass_options(adapt));
  Positions sum = Positions::Zero(3, c.net.topo.num_vertices);
  for (int k = 0; k < adapt; ++k) {
    EXPECT_EQ((h.state().mass_reference - c.x).cwiseAbs().maxCoeff(), 0.0) << "before " << k;
    EXPECT_FALSE(h.mass_info().thermal);
    h.sweep();
    if (k >= adapt / 2) sum += h.positions();
  }
  const Positions mean = sum / double(adapt - adapt / 2);
  EXPECT_GT((mean - c.x).cwiseAbs().maxCoeff(), 0.0) << "no trajectory was accepted";
  EXPECT_EQ((h.state().mass_reference - mean).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_TRUE(h.mass_info().thermal);
  EXPECT_EQ(h.mass_info().reference_transitions, adapt - adapt / 2);
  EXPECT_EQ(h.state().mass_reference_sum.size(), 0);
  // The matrix in use is the one built at the mean (its factor's size is a fingerprint of K0).
  const NetworkMassMatrix at_mean(c.net, c.load, mean, h.beta_per_pNum(),
                                  thermal_mass_options(adapt).hmc);
  EXPECT_EQ(h.mass_info().factor_nonzeros, at_mean.info().factor_nonzeros);
  EXPECT_EQ(h.mass_info().shift_pN_per_um, at_mean.info().shift_pN_per_um);
  for (int k = 0; k < 12; ++k) {
    h.sweep();
    EXPECT_EQ((h.state().mass_reference - mean).cwiseAbs().maxCoeff(), 0.0)
        << "production transition " << k;
  }
  EXPECT_GT((h.positions() - mean).cwiseAbs().maxCoeff(), 0.0);
}

// The equilibrium reference (the default) never moves the mass matrix.
TEST(HmcThermalMass, EquilibriumReferenceStaysAtTheStart) {
  const SmallCell c;
  McOptions o = thermal_mass_options(6);
  o.hmc.mass_reference = HmcMassReference::equilibrium;
  HmcSampler h(c.net, c.load, c.x, o);
  for (int k = 0; k < 10; ++k) h.sweep();
  EXPECT_EQ((h.state().mass_reference - c.x).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_FALSE(h.mass_info().thermal);
  EXPECT_EQ(h.state().mass_reference_sum.size(), 0);
}

TEST(HmcThermalMass, RefusesAnAdaptivePhaseTooShortToAverage) {
  const SmallCell c;
  EXPECT_THROW(HmcSampler(c.net, c.load, c.x, thermal_mass_options(1)), std::invalid_argument);
  EXPECT_NO_THROW(HmcSampler(c.net, c.load, c.x, thermal_mass_options(2)));
}

McRunSetup thermal_mass_setup(int adapt) {
  const SmallCell c;
  McRunSetup setup;
  setup.force_pN = c.load.force_pN;
  setup.multipliers = c.load.multipliers;
  setup.sampler = thermal_mass_options(adapt);
  setup.sampler.seed = 8;
  setup.sampler.hmc.trajectory_time = 1.2;
  setup.sampler.chains = 2;
  setup.penalty_scale = 1.0;
  return setup;
}

// Two chains checkpointed inside the averaging window (the file then holds the position sums)
// and after the rebuild, resumed on one thread, continue the straight two-thread run bit for bit;
// a state inside the window without its sum is refused.
TEST(HmcThermalMass, ResumesAcrossTheRebuildBitForBitOnAnyThreadCount) {
  const SmallCell c;
  const McRunSetup setup = thermal_mass_setup(8);  // window: transitions 4 .. 7
  const int saved = omp_get_max_threads();
  omp_set_num_threads(2);
  McRun whole(c.net, setup, c.x);
  whole.advance(14);
  omp_set_num_threads(saved);
  const auto dir = rbc::testing::fresh_output_dir("hmc_thermal_checkpoint");
  for (const long long at : {6LL, 10LL}) {
    const std::string file = (dir / ("chain_" + std::to_string(at) + ".h5")).string();
    McRun first(c.net, setup, c.x);
    first.advance(14, [&](const McRun& r) {
      if (r.sweeps_done() < at) return true;
      write_mc_checkpoint(file, c.net, McCheckpoint::of(r));
      return false;
    });
    const McCheckpoint cp = read_mc_checkpoint(file, c.net);
    EXPECT_EQ(cp.setup.sampler.hmc.mass_reference, HmcMassReference::thermal);
    ASSERT_EQ(cp.chains.size(), 2u);
    for (const McChainState& s : cp.chains)
      EXPECT_EQ(s.mass_reference_sum.size() > 0, at == 6) << "checkpoint at " << at;
    if (at == 6) {
      McChainState without = cp.chains[0];
      without.mass_reference_sum.resize(3, 0);
      LoadState load;
      load.force_pN = cp.setup.force_pN;
      load.multipliers = cp.setup.multipliers;
      load.stiffness_scale = cp.setup.penalty_scale;
      HmcSampler h(c.net, load, without.x, without.mass_reference, cp.setup.sampler);
      EXPECT_THROW(h.restore(without), std::invalid_argument);
    }
    omp_set_num_threads(1);
    McRun resumed(c.net, cp.setup, cp.chains, cp.chain_series);
    resumed.advance(14);
    omp_set_num_threads(saved);
    for (int k = 0; k < 2; ++k) {
      const McChainState a = whole.states()[std::size_t(k)], b = resumed.states()[std::size_t(k)];
      EXPECT_EQ((a.x - b.x).cwiseAbs().maxCoeff(), 0.0) << "chain " << k << " from " << at;
      EXPECT_EQ((a.mass_reference - b.mass_reference).cwiseAbs().maxCoeff(), 0.0);
      EXPECT_GT((a.mass_reference - c.x).cwiseAbs().maxCoeff(), 0.0) << "not rebuilt";
      EXPECT_EQ(a.step_um, b.step_um);
      ASSERT_EQ(whole.series(k).size(), resumed.series(k).size());
      for (std::size_t i = 0; i < whole.series(k).size(); ++i)
        EXPECT_EQ(whole.series(k)[i].energy_pNum, resumed.series(k)[i].energy_pNum) << i;
    }
    EXPECT_TRUE(dynamic_cast<const HmcSampler&>(resumed.chain(0)).mass_info().thermal);
  }
  omp_set_num_threads(1);
  McRun serial(c.net, setup, c.x);
  serial.advance(14);
  omp_set_num_threads(saved);
  for (int k = 0; k < 2; ++k)
    EXPECT_EQ((whole.states()[std::size_t(k)].x - serial.states()[std::size_t(k)].x)
                  .cwiseAbs()
                  .maxCoeff(),
              0.0)
        << "chain " << k << ": two threads against one";
}

// Which matrix a chain uses after the adaptive phase travels with its state and its checkpoint:
// a chain whose rebuild at the mean could not be made keeps the start's matrix and, resumed,
// still says so (mass_info().thermal false, no averaged transitions), beside a chain that was
// rebuilt; a file whose flag claims the thermal matrix before the phase ended is refused.
TEST(HmcThermalMass, WhichMatrixAChainUsesSurvivesACheckpoint) {
  const SmallCell c;
  const McRunSetup setup = thermal_mass_setup(8);  // window: transitions 4 .. 7
  McRun run(c.net, setup, c.x);
  run.advance(10);
  McCheckpoint cp = McCheckpoint::of(run);
  ASSERT_EQ(cp.chains.size(), 2u);
  EXPECT_TRUE(cp.chains[0].mass_at_thermal_mean);
  EXPECT_TRUE(cp.chains[1].mass_at_thermal_mean);
  // Chain 1 as after a failed rebuild: the start's reference and matrix.
  cp.chains[1].mass_reference = c.x;
  cp.chains[1].mass_at_thermal_mean = false;
  const auto dir = rbc::testing::fresh_output_dir("hmc_thermal_flag");
  const std::string file = (dir / "chains.h5").string();
  write_mc_checkpoint(file, c.net, cp);
  const McCheckpoint back = read_mc_checkpoint(file, c.net);
  EXPECT_TRUE(back.chains[0].mass_at_thermal_mean);
  EXPECT_FALSE(back.chains[1].mass_at_thermal_mean);
  McRun resumed(c.net, back.setup, back.chains, back.chain_series);
  const auto& rebuilt = dynamic_cast<const HmcSampler&>(resumed.chain(0));
  const auto& kept = dynamic_cast<const HmcSampler&>(resumed.chain(1));
  EXPECT_TRUE(rebuilt.mass_info().thermal);
  EXPECT_EQ(rebuilt.mass_info().reference_transitions, 4);
  EXPECT_FALSE(kept.mass_info().thermal);
  EXPECT_EQ(kept.mass_info().reference_transitions, 0);
  EXPECT_EQ(mc_run_json(c.net, resumed).at("hmc").at("mass_built_at"), "thermal mean");
  resumed.advance(12);
  EXPECT_FALSE(resumed.states()[1].mass_at_thermal_mean);
  EXPECT_EQ((resumed.states()[1].mass_reference - c.x).cwiseAbs().maxCoeff(), 0.0);

  // The thermal matrix claimed before the adaptive phase ended: refused on reading and restoring.
  McRun early(c.net, setup, c.x);
  early.advance(5);
  McCheckpoint bad = McCheckpoint::of(early);
  bad.chains[0].mass_at_thermal_mean = true;
  const std::string bad_file = (dir / "early.h5").string();
  write_mc_checkpoint(bad_file, c.net, bad);
  try {
    read_mc_checkpoint(bad_file, c.net);
    ADD_FAILURE() << "a flag before the adaptive phase ended was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("mass matrix flag (1)"), std::string::npos) << e.what();
  }
  LoadState load;
  load.force_pN = setup.force_pN;
  load.multipliers = setup.multipliers;
  load.stiffness_scale = setup.penalty_scale;
  HmcSampler h(c.net, load, bad.chains[0].x, bad.chains[0].mass_reference, setup.sampler);
  EXPECT_THROW(h.restore(bad.chains[0]), std::invalid_argument);
}

// The law is unchanged: independent chains with the thermal and the equilibrium reference, from
// the zero-temperature equilibrium at 88 pN (the start `rbc mc` uses), give the same means of the
// energy, D_A, D_T, area and volume, each within 3.5 combined (autocorrelation-corrected) errors
// (five comparisons: a false alarm below 5 x 4.7e-4).
TEST(HmcThermalMass, SamplesTheEquilibriumReferencesLaw) {
  const SmallCell c;
  McRunSetup base = thermal_mass_setup(100);
  base.force_pN = 88.0;
  base.penalty_scale = 25.0;
  base.sampler.hmc.area_volume = HmcAreaVolume::penalty;  // area and volume fluctuate
  base.sampler.hmc.trajectory_time = McOptions{}.hmc.trajectory_time;
  McZeroTemperatureStart z;
  {
    SerialOpenMpScope serial;
    z = mc_zero_temperature_start(c.net, base, McStartOptions{});
  }
  ASSERT_TRUE(z.converged);
  auto run = [&](HmcMassReference ref, unsigned long seed) {
    McRunSetup setup = base;
    setup.sampler.hmc.mass_reference = ref;
    setup.sampler.seed = seed;
    McRun r(c.net, setup, z.start);
    r.advance(900);
    return r.summarise();
  };
  const McSummary t = run(HmcMassReference::thermal, 31);
  const McSummary e = run(HmcMassReference::equilibrium, 32);
  auto compare = [](const char* name, const BlockingResult& a, const BlockingResult& b) {
    const double combined = std::hypot(a.error, b.error);
    EXPECT_GT(combined, 0.0) << name;
    EXPECT_NEAR(a.mean, b.mean, 3.5 * combined)
        << name << ": thermal " << a.mean << " +- " << a.error << " (g " << a.inefficiency
        << "), equilibrium " << b.mean << " +- " << b.error << " (g " << b.inefficiency << ")";
  };
  compare("energy", t.energy, e.energy);
  compare("D_A", t.axial, e.axial);
  compare("D_T", t.transverse, e.transverse);
  compare("area", t.area, e.area);
  compare("volume", t.volume, e.volume);
}

}  // namespace
}  // namespace rbc
