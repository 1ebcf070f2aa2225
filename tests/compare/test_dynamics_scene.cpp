// SPDX-License-Identifier: GPL-3.0-or-later
// The dynamics scenes of compare/dynamics_scene.hpp: the options' limits (InvalidParameter
// naming the quantity, the limit and the value), cancellation between steps, a stretch whose
// trajectory ends at the static equilibrium of the same force, and the network's parameters
// reaching both models (a larger persistence length is a softer network).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "compare/dynamics_scene.hpp"
#include "invalid_parameter.hpp"

namespace rbc {
namespace {

DynamicsSceneOptions small_discrete() {
  DynamicsSceneOptions o;
  o.model = DynamicsModel::discrete;
  o.vertices = 250;
  o.force_pN = 50;
  o.duration_s = 0.05;
  o.dt_s = 0.005;
  return o;
}

std::string refusal(const DynamicsSceneOptions& o) {
  return testing::limit_refusal([&] { o.validate(); });
}

TEST(DynamicsScene, ValidateNamesTheQuantityTheLimitAndTheValue) {
  DynamicsSceneOptions o = small_discrete();
  EXPECT_NO_THROW(o.validate());
  o.dt_s = 0;
  EXPECT_EQ(refusal(o), "time step dt must be finite and > 0 s, got 0 s");
  o = small_discrete();
  o.dt_s = 0.1;
  EXPECT_EQ(refusal(o), "time step dt must be at most the duration 0.05 s, got 0.1 s");
  o = small_discrete();
  o.force_pN = 501;
  EXPECT_EQ(refusal(o), "force (discrete model) must be finite and in (0, 500] pN, got 501 pN");
  o.model = DynamicsModel::continuum;
  EXPECT_EQ(refusal(o), "force (continuum model) must be finite and in (0, 400] pN, got 501 pN");
  o.force_pN = 0;  // release and stretch need a force; relax does not apply it
  EXPECT_NE(refusal(o).find("(0, 400] pN, got 0 pN"), std::string::npos);
  o.scene = DynamicsScene::relax;
  EXPECT_NO_THROW(o.validate());
  o.model = DynamicsModel::discrete;
  EXPECT_NE(refusal(o).find("scene must be release or stretch for the discrete model"),
            std::string::npos);
  o = small_discrete();
  o.membrane_viscosity_pN_s_per_um = std::nan("");
  EXPECT_EQ(refusal(o), "membrane viscosity must be finite and > 0 pN s/um, got nan");
  o = small_discrete();
  o.vertices = 99;
  EXPECT_EQ(refusal(o), "vertices must be an integer in [100, 40000], got 99");
  o = small_discrete();
  o.regulariser = 0;
  EXPECT_NE(refusal(o).find("(0, 1]"), std::string::npos);
  o = small_discrete();
  o.model = DynamicsModel::continuum;
  o.scheme = TimeScheme::bdf2;
  EXPECT_NE(refusal(o).find("time scheme must be be for the continuum model"), std::string::npos);
  o = small_discrete();
  o.network.wlc.persistence_um = -1;  // the network's own validate()
  EXPECT_NE(refusal(o).find("persistence"), std::string::npos);
  EXPECT_THROW(run_dynamics_scene(o), InvalidParameter);
  EXPECT_THROW(dynamics_scene_from_string("relaxed"), InvalidParameter);
  EXPECT_EQ(to_string(dynamics_scene_from_string("relax")), "relax");
  EXPECT_EQ(time_scheme_name(time_scheme_from_string("bdf2")), "bdf2");
}

// The cancel hook is polled before every time step (and by the static solves, which are the
// same for two durations): 20 steps poll it 10 times more than 10 steps. Returning true stops
// the run by throwing Cancelled at that poll.
TEST(DynamicsScene, CancelIsPolledBeforeEveryStepAndStopsTheRun) {
  const auto polls = [](double duration_s) {
    DynamicsSceneOptions o = small_discrete();
    o.duration_s = duration_s;
    int n = 0;
    o.cancel = [&n] {
      ++n;
      return false;
    };
    EXPECT_TRUE(run_dynamics_scene(o).converged());
    return n;
  };
  const int ten_steps = polls(0.05), twenty_steps = polls(0.1);
  EXPECT_EQ(twenty_steps - ten_steps, 10);
  DynamicsSceneOptions o = small_discrete();
  int n = 0;
  o.cancel = [&n, ten_steps] { return ++n >= ten_steps; };  // the last step's poll
  EXPECT_THROW(run_dynamics_scene(o), Cancelled);
  EXPECT_EQ(n, ten_steps);
}

// A stretch's trajectory creeps to the static equilibrium at the same force: over ten
// Kelvin-Voigt times (eta_m/mu ~ 0.084 s) D_A rises monotonically from the rest shape's and
// ends within 0.02 % of the static D_A (solved independently by the static solver). The steps
// are solved to 0.01 pN/s x dt = 5e-4 pN: at the default 1 pN/s (0.05 pN) the creep stops
// once the remaining force is below the tolerance, 0.2 % short of the static D_A.
TEST(DynamicsScene, StretchTrajectoryEndsAtTheStaticEquilibrium) {
  DynamicsSceneOptions o = small_discrete();
  o.scene = DynamicsScene::stretch;
  o.duration_s = 1.0;
  o.dt_s = 0.05;
  o.tolerance_pN_per_s = 0.01;
  const DynamicsSceneResult r = run_dynamics_scene(o);
  ASSERT_TRUE(r.converged()) << r.trajectory.status;
  const auto& s = r.trajectory.samples;
  ASSERT_EQ(s.size(), 21u);
  EXPECT_NEAR(s.front().axial_um, r.rest_axial_um, 1e-9);
  for (size_t k = 1; k < s.size(); ++k) EXPECT_GT(s[k].axial_um, s[k - 1].axial_um) << k;
  EXPECT_GT(r.static_axial_um - r.rest_axial_um, 0.5);  // the stretch is not trivial
  EXPECT_NEAR(s.back().axial_um / r.static_axial_um, 1.0, 2e-4);
  EXPECT_NEAR(s.back().transverse_um / r.static_transverse_um, 1.0, 2e-4);
  const nlohmann::json j = dynamics_summary_json(o, r);
  EXPECT_EQ(j.at("samples").size(), s.size());
  EXPECT_EQ(j.at("final_axial_relative_to_static").get<double>(),
            s.back().axial_um / r.static_axial_um - 1);
}

// The WLC link stiffness scales as k_B T/p: a LARGER persistence length p is a SOFTER network.
// With p = 10 nm instead of 7.5 nm the closed-form shear modulus is 7.5/10 of the default's (the
// steric term scales with the WLC's prefactor too), so the Kelvin-Voigt time eta_m/mu grows by
// 10/7.5, and both models stretch further at the same force.
TEST(DynamicsScene, LargerPersistenceLengthIsASofterNetworkInBothModels) {
  for (const DynamicsModel model : {DynamicsModel::discrete, DynamicsModel::continuum}) {
    SCOPED_TRACE(to_string(model));
    DynamicsSceneOptions o = small_discrete();
    o.model = model;
    o.elements = 400;
    o.duration_s = o.dt_s;  // one step: the static equilibria are what is compared
    DynamicsSceneOptions soft = o;
    soft.network.wlc.persistence_um = 10e-3;
    const DynamicsSceneResult a = run_dynamics_scene(o), b = run_dynamics_scene(soft);
    ASSERT_TRUE(a.converged() && b.converged());
    EXPECT_NEAR(b.shear_modulus_pN_per_um / a.shear_modulus_pN_per_um, 7.5 / 10.0, 1e-12);
    EXPECT_NEAR(b.kelvin_voigt_time_s / a.kelvin_voigt_time_s, 10.0 / 7.5, 1e-12);
    EXPECT_NEAR(b.rest_axial_um, a.rest_axial_um, 0.05);  // the rest shape barely changes
    EXPECT_GT(b.loaded_axial_um - b.rest_axial_um, 1.1 * (a.loaded_axial_um - a.rest_axial_um));
  }
}

}  // namespace
}  // namespace rbc
