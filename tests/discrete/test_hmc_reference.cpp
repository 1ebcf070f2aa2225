// SPDX-License-Identifier: GPL-3.0-or-later
// Long reference runs (label "slow", `ctest -L slow`): the collective sampler and the
// single-vertex Metropolis sampler give the same means of D_A, D_T, the energy, the area and the
// volume for the cell at 88 pN and 300 K, each with a converged error estimate.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "core/rest_shape.hpp"
#include "core/units.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/mc_workflow.hpp"

namespace rbc {
namespace {

McSummary run_chain(const Network& net, McAlgorithm algorithm, long long sweeps, int adapt,
                    HmcAreaVolume area_volume = HmcAreaVolume::penalty) {
  McRunSetup setup;
  setup.sampler.hmc.area_volume = area_volume;
  setup.force_pN = 88.0;
  setup.sampler.temperature_K = 300.0;
  setup.sampler.seed = algorithm == McAlgorithm::hmc ? 11 : 12;
  setup.sampler.streams = 2;
  setup.sampler.algorithm = algorithm;
  setup.sampler.adapt_sweeps = adapt;
  McStartOptions so;
  McZeroTemperatureStart z;
  {
    SerialOpenMpScope serial;
    z = mc_zero_temperature_start(net, setup, so);
  }
  EXPECT_TRUE(z.converged);
  McRun run(net, setup, z.start);
  run.advance(sweeps);
  return run.summarise();
}

// Five means compared at N = 500 (ten comparisons with the N = 2,000 case of the note): each
// within 3.5 combined errors, both errors converged (Geyer's window closed with >= 50 effective
// samples). Metropolis needs ~2,000 sweeps per independent D_A (inefficiency measured at 40,000
// sweeps: 1,900, not yet converged), so it runs 400,000 sweeps; HMC runs 15,000 trajectories
// (about 100 s of the test's 9 minutes). HMC's acceptance is not stationary at this size (blocks of
// 1,000 trajectories range from 0.03 to 0.40), and on some processors its inefficiencies of the
// energy and the area exceed 300 trajectories, so their errors do not converge and this test
// fails: docs/validation/monte-carlo.md states it.
TEST(SlowReferenceHmc, SamplesTheMetropolisLawAtN500) {
  RestShapeOptions ro;
  ro.target_vertices = 500;
  const Network net = build_network(make_rest_shape(ro), NetworkParameters{});
  const McSummary h = run_chain(net, McAlgorithm::hmc, 15000, 300);
  const McSummary m = run_chain(net, McAlgorithm::metropolis, 400000, 4000);
  auto compare = [](const char* name, const BlockingResult& a, const BlockingResult& b) {
    EXPECT_TRUE(a.converged) << name << " (hmc) error not converged";
    EXPECT_TRUE(b.converged) << name << " (metropolis) error not converged";
    const double combined = std::hypot(a.error, b.error);
    EXPECT_NEAR(a.mean, b.mean, 3.5 * combined)
        << name << ": hmc " << a.mean << " +- " << a.error << " (g " << a.inefficiency
        << "), metropolis " << b.mean << " +- " << b.error << " (g " << b.inefficiency << ")";
    std::printf("%-12s hmc %.6f +- %.6f (g %.2f)  metropolis %.6f +- %.6f (g %.1f)  z %.2f\n", name,
                a.mean, a.error, a.inefficiency, b.mean, b.error, b.inefficiency,
                (a.mean - b.mean) / combined);
  };
  compare("D_A", h.axial, m.axial);
  compare("D_T", h.transverse, m.transverse);
  compare("energy", h.energy, m.energy);
  compare("area", h.area, m.area);
  compare("volume", h.volume, m.volume);
}

// Exact area and volume constraints sample the limit of infinitely stiff penalties; the
// Metropolis sampler's penalties (scale 25) hold A and V to about 1e-5, so the two laws differ
// below this test's resolution in D_A and D_T. The energy differs by the penalties' own
// equipartition: each of the two stiff modes holds kB T / 2 under the penalties and none under
// the constraints, so the HMC energy plus kB T is compared. HMC with constraints runs 3,000
// trajectories (inefficiencies of 3 to 5 at N = 500), Metropolis the 400,000 sweeps above.
TEST(SlowReferenceHmc, ExactConstraintsSampleTheStiffPenaltyLawAtN500) {
  RestShapeOptions ro;
  ro.target_vertices = 500;
  const Network net = build_network(make_rest_shape(ro), NetworkParameters{});
  const McSummary h = run_chain(net, McAlgorithm::hmc, 3000, 300, HmcAreaVolume::exact);
  const McSummary m = run_chain(net, McAlgorithm::metropolis, 400000, 4000);
  const double kt = units::thermal_energy_pNum(300.0);
  auto compare = [](const char* name, const BlockingResult& a, const BlockingResult& b,
                    double shift) {
    EXPECT_TRUE(a.converged) << name << " (hmc) error not converged";
    EXPECT_TRUE(b.converged) << name << " (metropolis) error not converged";
    const double combined = std::hypot(a.error, b.error);
    EXPECT_NEAR(a.mean + shift, b.mean, 3.5 * combined)
        << name << ": hmc " << a.mean << " + " << shift << " +- " << a.error << " (g "
        << a.inefficiency << "), metropolis " << b.mean << " +- " << b.error << " (g "
        << b.inefficiency << ")";
    std::printf("%-12s hmc %.6f +- %.6f (g %.2f)  metropolis %.6f +- %.6f (g %.1f)  z %.2f\n", name,
                a.mean + shift, a.error, a.inefficiency, b.mean, b.error, b.inefficiency,
                (a.mean + shift - b.mean) / combined);
  };
  compare("D_A", h.axial, m.axial, 0.0);
  compare("D_T", h.transverse, m.transverse, 0.0);
  compare("energy", h.energy, m.energy, kt);
  // The constraints hold to their Newton tolerance, 1e-10 of A0 and V0.
  EXPECT_NEAR(h.area.mean, net.area0_um2, 1e-9 * net.area0_um2);
  EXPECT_NEAR(h.volume.mean, net.volume0_um3, 1e-9 * net.volume0_um3);
}

}  // namespace
}  // namespace rbc
