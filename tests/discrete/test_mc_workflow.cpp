// SPDX-License-Identifier: GPL-3.0-or-later
// The Monte Carlo workflow of `rbc mc` / Python MonteCarlo as library functions
// (discrete/mc_workflow.hpp): zero-temperature start, resume rules, summary JSON.
#include <gtest/gtest.h>

#include <stdexcept>

#include "core/rest_shape.hpp"
#include "discrete/mc_workflow.hpp"

namespace rbc {
namespace {

Network small_network() {
  RestShapeOptions o;
  o.target_vertices = 150;
  return build_network(make_rest_shape(o), NetworkParameters{});
}

TEST(McWorkflow, ZeroTemperatureStartIsTheContinuationsEquilibrium) {
  const Network net = small_network();
  McRunSetup setup;
  setup.force_pN = 60.0;  // mc_startup_forces: 30, 60
  McStartOptions so;
  const McZeroTemperatureStart z = mc_zero_temperature_start(net, setup, so);
  ASSERT_TRUE(z.converged) << to_string(z.equilibrium.status);
  // The same continuation by hand gives the same equilibrium, multipliers and references.
  Positions x = net.rest;
  ConstraintMultipliers l;
  StretchPoint p;
  for (double f : mc_startup_forces(60.0)) p = solve_equilibrium(net, f, x, l, StretchOptions{});
  EXPECT_EQ(z.equilibrium.axial_um, p.axial_um);
  EXPECT_EQ(setup.reference_axial_um, p.axial_um);
  EXPECT_EQ(setup.reference_transverse_um, p.transverse_um);
  EXPECT_EQ(setup.multipliers.area_pN_per_um, l.area_pN_per_um);
  EXPECT_EQ(setup.multipliers.volume_pN_per_um2, l.volume_pN_per_um2);
  EXPECT_TRUE(z.start.isApprox(x, 0.0));
  // --start rest: the rest shape with the same multipliers.
  McRunSetup s2;
  s2.force_pN = 60.0;
  so.start = McStart::rest;
  const McZeroTemperatureStart r = mc_zero_temperature_start(net, s2, so);
  EXPECT_TRUE(r.start.isApprox(net.rest, 0.0));
  EXPECT_EQ(s2.multipliers.area_pN_per_um, l.area_pN_per_um);
  EXPECT_EQ(mc_start_from_string("rest"), McStart::rest);
  EXPECT_THROW(mc_start_from_string("nowhere"), std::invalid_argument);
}

TEST(McWorkflow, ResumeRulesRefuseAnotherChainAndNoteAnExtendedAdaptivePhase) {
  McCheckpoint cp;
  cp.setup.force_pN = 88.0;
  cp.setup.sampler.temperature_K = 300.0;
  cp.setup.sampler.seed = 7;
  cp.setup.sampler.adapt_sweeps = 200;
  cp.schedule.planned_sweeps = 1000;
  cp.schedule.adapt_fraction = 0.2;
  McResumeRequest r;
  r.total_sweeps = 1000;
  EXPECT_EQ(check_mc_resume(cp, r, "c.h5"), "");  // a straight 1000-sweep run adapts 200 too
  r.force_pN = 88.0 * (1 + 1e-14);                // equal within 1e-12
  EXPECT_EQ(check_mc_resume(cp, r, "c.h5"), "");
  r.force_pN = 90.0;
  EXPECT_THROW(check_mc_resume(cp, r, "c.h5"), std::invalid_argument);
  r.force_pN.reset();
  r.seed = 8;
  EXPECT_THROW(check_mc_resume(cp, r, "c.h5"), std::invalid_argument);
  r.seed.reset();
  r.adapt_sweeps = 100;
  EXPECT_THROW(check_mc_resume(cp, r, "c.h5"), std::invalid_argument);
  r.adapt_sweeps.reset();
  r.total_sweeps = 2000;  // a straight 2000-sweep run would adapt 400: noted, not refused
  const std::string note = check_mc_resume(cp, r, "c.h5");
  EXPECT_NE(note.find("sweeps 1-200"), std::string::npos) << note;
  EXPECT_NE(note.find("sweeps 1-400"), std::string::npos) << note;
  cp.schedule.adapt_fraction = -1;  // given absolute: never a note
  EXPECT_EQ(check_mc_resume(cp, r, "c.h5"), "");
  McCheckpointNetwork cn;
  r.bending_model = BendingModel::dihedral;
  EXPECT_THROW(check_mc_resume_network(cn, r, "c.h5"), std::invalid_argument);
  r.bending_model = BendingModel::juelicher;
  EXPECT_NO_THROW(check_mc_resume_network(cn, r, "c.h5"));
}

TEST(McWorkflow, SummaryJsonCarriesTheStatisticsAndTheThermalShift) {
  McSummary s;
  s.samples = 100;
  s.axial.mean = 8.5;
  s.axial.variance = 4e-4;
  s.transverse.mean = 7.25;
  McRunSetup su;
  su.reference_axial_um = 8.25;
  su.reference_transverse_um = 7.5;
  const nlohmann::json j = to_json(s, su);
  EXPECT_EQ(j.at("samples"), 100);
  EXPECT_DOUBLE_EQ(j.at("thermal_shift_axial_um").get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(j.at("thermal_shift_transverse_um").get<double>(), -0.25);
  EXPECT_DOUBLE_EQ(j.at("axial_um").at("std").get<double>(), 0.02);
  for (const char* k : {"energy_pNum", "transverse_um", "area_um2", "volume_um3"})
    EXPECT_TRUE(j.at(k).contains("blocking_converged")) << k;
}

}  // namespace
}  // namespace rbc
