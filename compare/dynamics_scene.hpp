// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The scenes of `rbc dynamics` for either model (MODEL.md section 6): overdamped dynamics by
// backward Euler (or BDF2, discrete) minimising movements from a static equilibrium.
//  - release: the equilibrium at the bead force F, then F = 0 from t = 0: the shape recovery of
//    Hochmuth, Worthy & Evans (1979), with the fitted recovery time t_c;
//  - stretch: the rest equilibrium, then F from t = 0: the time course of a stretch (paper
//    Fig. 6), compared with the static equilibrium at F;
//  - relax (continuum only): the Helfrich relaxation of the Evans-Fung shape at fixed area and
//    volume (paper Fig. 5), compared with the static relaxation relax_helfrich.
// run_dynamics_scene() is what `rbc dynamics` and rbc.dynamics() run; dynamics_summary_json()
// is the JSON both report (`rbc dynamics --json`, DynamicsResult.to_dict()). No printing here.
#include <nlohmann/json.hpp>
#include <string>

#include "continuum/relax.hpp"
#include "core/progress.hpp"
#include "discrete/dynamics.hpp"
#include "discrete/network.hpp"
#include "discrete/wlc.hpp"

namespace rbc {

enum class DynamicsModel { discrete, continuum };
enum class DynamicsScene { release, stretch, relax };

std::string to_string(DynamicsModel m);  ///< "discrete" | "continuum"
std::string to_string(DynamicsScene s);  ///< "release" | "stretch" | "relax"
/// "be" (backward Euler) | "bdf2".
std::string time_scheme_name(TimeScheme s);
/// Parse the names above; rbc::InvalidParameter (quantity "model", "scene", "time scheme")
/// naming the value and the choices otherwise.
DynamicsModel dynamics_model_from_string(const std::string& name);
DynamicsScene dynamics_scene_from_string(const std::string& name);
TimeScheme time_scheme_from_string(const std::string& name);

struct DynamicsSceneOptions {
  DynamicsModel model = DynamicsModel::continuum;
  DynamicsScene scene = DynamicsScene::release;
  /// backward_euler (energy-monotone) | bdf2 (second order; discrete model only).
  TimeScheme scheme = TimeScheme::backward_euler;
  /// Total bead force F (pN): in (0, kMaxDiscreteForce_pN] (discrete) or
  /// (0, kMaxContinuumForce_pN] (continuum) for release and stretch; [0, max] for relax,
  /// which does not apply it.
  double force_pN = 88.0;
  /// Membrane shear viscosity eta_m (pN s/um = Pa s um), > 0; Hochmuth 1979 range 0.6-0.8
  /// with mu ~ 6 uN/m.
  double membrane_viscosity_pN_s_per_um = 0.7;
  /// Continuum: dilatational over shear viscosity eta_d/eta_m, >= 0 (the network's value is 2).
  double dilatational_ratio = 2.0;
  double duration_s = 0.5;  ///< simulated time T (s), > 0
  double dt_s = 1e-3;       ///< time step (s), in (0, duration_s]
  /// Step force tolerance per unit dt (pN/s), >= 0; 0 = the scene's default
  /// (step_tolerance_pN_per_s()).
  double tolerance_pN_per_s = 0.0;
  /// Relax: the fluids' normal drag per area (pN s/um^3, > 0; continuum/dynamics.hpp).
  double normal_drag_pN_s_per_um3 = 3.5e-3;
  /// Relax: in-plane mesh regulariser, fraction of the p = 2 law in (0, 1] (as `rbc relax
  /// --regulariser`).
  double regulariser = 0.01;
  int vertices = 500;   ///< discrete: network vertices, [100, 40000]
  int elements = 1000;  ///< continuum: triangles, [kMinContinuumElements, kMaxContinuumElements]
  /// Continuum in-plane law: the WLC expansion to order 2, 3, 4 or full.
  WlcExpansion order = WlcExpansion::order2;
  int max_halvings = 4;  ///< halvings of a failing step's dt, [0, 20]
  /// Solver iterations per step, >= 0: L-BFGS per multiplier update (discrete), Newton
  /// (continuum); 0 = the library defaults (20,000 L-BFGS iterations per update; 50 Newton).
  int step_iterations = 0;
  /// The physics of both models: spectrin WLC, steric, bending, bead patches (the discrete
  /// network is built from all of it; the continuum law from wlc and steric, its bending and
  /// bead patches from bending and tweezers). Default: the paper's parameters.
  NetworkParameters network;
  /// Directory of hochmuth1979_recovery.csv (release); empty = default_data_directory().
  std::string data_dir;
  /// Polled before every time step and by the static solves; true stops the run by throwing
  /// Cancelled.
  CancelCheck cancel;

  /// Throws rbc::InvalidParameter naming the quantity, the value and the limit (quantities:
  /// "model", "scene", "time scheme", "time step dt", "duration", "membrane viscosity",
  /// "dilatational ratio eta_d/eta_m", "force (discrete model)", "force (continuum model)",
  /// "step tolerance", "regulariser (fraction of the p=2 law)", "normal drag", "vertices",
  /// "elements", "max halvings", "step iterations"; and NetworkParameters::validate()'s).
  void validate() const;
  /// The step force tolerance per unit dt (pN/s): tolerance_pN_per_s, or by default 1 pN/s for
  /// the in-plane scenes (elastic forces ~ pN: 1e-3 pN at dt = 1 ms) and 1e-5 pN/s for relax
  /// (bending forces ~ 1e-2 pN per vertex at 400 elements; a step of 1 s is solved to 1e-5 pN).
  double step_tolerance_pN_per_s() const;
  /// Steps between samples: 1, or steps/1000 for runs of more than 2,000 steps.
  int sample_every() const;
};

struct DynamicsSceneResult {
  /// The samples (time, D_A, D_T, energy, drifts, iterations) and positions at each sample.
  TrajectoryResult trajectory;
  Faces faces;
  int vertices = 0, elements = 0;  ///< elements: continuum only (0 for discrete)
  std::string law;                 ///< continuum in-plane law name
  /// The static solves (release, stretch): both equilibria converged; otherwise the
  /// trajectory was not run and status/residual say why.
  bool static_converged = true;
  std::string static_status;
  double static_residual_pN = 0;
  double lambda_inf = 1.0;                               ///< D_A/D_T at the zero-force equilibrium
  double rest_axial_um = 0, loaded_axial_um = 0;         ///< static D_A at 0 and at F
  double static_axial_um = 0, static_transverse_um = 0;  ///< static end state of the scene
  double force_dynamics_pN = 0;                          ///< the force during the trajectory
  /// Shear modulus mu (closed form of the network's WLC and steric parameters) and the
  /// Kelvin-Voigt time eta_m/mu.
  double shear_modulus_pN_per_um = 0, kelvin_voigt_time_s = 0;
  /// Release: the fit of Hochmuth's measure to the trajectory, and the fit of Hochmuth's
  /// curve (hochmuth_read false when the data file was not read).
  RecoveryFit recovery;
  RecoveryFit hochmuth;
  bool hochmuth_read = false;
  /// Relax: disc diameters of the first and last frame, and the static relaxation at the same
  /// mesh, bending and regulariser.
  double relax_disc_before_um = 0, relax_disc_after_um = 0;
  DiscShape relax_end;
  DiscShape relax_static;
  bool relax_static_converged = false;

  /// Static solves and trajectory converged: the run is a result.
  bool converged() const { return static_converged && trajectory.converged; }
};

/// Runs the scene: validate(), the static equilibria (or the rest shape for relax), the
/// trajectory, then the scene's measures. Progress goes to `progress`; options.cancel stops the
/// run by throwing Cancelled. A static solve or a step that does not converge is reported in
/// the result (converged() false), not thrown.
DynamicsSceneResult run_dynamics_scene(const DynamicsSceneOptions& options,
                                       const ProgressSink& progress = {});

/// The JSON summary `rbc dynamics --json` prints (without the CLI's run record): the options,
/// the measures, the fluids' estimated share of the dissipation and the samples (t_s, axial_um,
/// transverse_um, energy_pNum): all of them up to 399, else every k-th with k = samples/200.
/// For a converged result.
nlohmann::json dynamics_summary_json(const DynamicsSceneOptions& options,
                                     const DynamicsSceneResult& result);

}  // namespace rbc
