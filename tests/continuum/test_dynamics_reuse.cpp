// SPDX-License-Identifier: GPL-3.0-or-later
// Factorisation reuse in the continuum backward-Euler step (continuum/dynamics.hpp): chord
// steps across iterations and time steps, with the extrapolated start, converge to the same
// trajectory as plain Newton (one fresh factorisation per iteration) within the step
// tolerance's effect, and do so with fewer factorisations than steps.
#include <gtest/gtest.h>

#include <cmath>

#include "continuum/continuum_stretch.hpp"
#include "continuum/dynamics.hpp"
#include "fixtures.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc {
namespace {

TEST(ContinuumDynamicsReuse, ChordStepsFollowThePlainNewtonTrajectory) {
  testing::OneOpenMpThread one;
  const ContinuumModel model = build_continuum_model(
      make_continuum_mesh(400),
      make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::order2), {});
  const ContinuumStretchPoint eq = run_continuum_stretch(model, {60.0}, ContinuumOptions{}).back();
  ASSERT_TRUE(eq.converged);
  const double dt = 0.005;
  const int steps = 12;
  auto run = [&](bool reuse, ContinuumDynamics::Counters& counters) {
    ContinuumDynamicsOptions o;
    o.tolerance_pN_per_s = 0.01;  // 5e-5 pN per step
    o.reuse_factorisation = reuse;
    o.extrapolate_start = reuse;
    ContinuumDynamics dyn(model, o);
    DynamicsState s{eq.x, eq.multipliers};
    for (int k = 0; k < steps; ++k) {
      const StepOutcome r = dyn.step(0.0, dt, s);
      EXPECT_TRUE(r.converged) << k << " " << r.status;
    }
    counters = dyn.counters();
    return dyn.measure(0.0, s);
  };
  ContinuumDynamics::Counters plain, chord;
  const TrajectorySample a = run(false, plain);
  const TrajectorySample b = run(true, chord);
  // A residual r moves a vertex by ~ r dt / (eta_m a_v) ~ 5e-5 x 5e-3 / (0.7 x 0.3) ~ 1e-6 um
  // per step; the time-discretisation error at this dt is ~ 1e-2 um.
  EXPECT_LT(std::abs(a.axial_um - b.axial_um), 1e-4);
  EXPECT_LT(std::abs(a.transverse_um - b.transverse_um), 1e-4);
  EXPECT_LT(std::abs(a.energy_pNum - b.energy_pNum), 1e-6 * std::abs(a.energy_pNum));
  EXPECT_EQ(plain.chord_steps, 0);
  EXPECT_GE(plain.factorisations, plain.iterations);
  EXPECT_GT(chord.chord_steps, 0);
  // Measured: plain 65 iterations, 109 factorisations (shift retries included); chord 103
  // iterations of which 83 chord steps, 34 factorisations.
  EXPECT_LT(2 * chord.factorisations, plain.factorisations);
}

}  // namespace
}  // namespace rbc
