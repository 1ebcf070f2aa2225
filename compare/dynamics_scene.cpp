// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/dynamics_scene.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "compare/experiment.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/dynamics.hpp"
#include "core/io.hpp"
#include "core/rest_shape.hpp"
#include "core/validation.hpp"
#include "discrete/stretch.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {

std::string to_string(DynamicsModel m) {
  return m == DynamicsModel::discrete ? "discrete" : "continuum";
}

std::string to_string(DynamicsScene s) {
  switch (s) {
    case DynamicsScene::release:
      return "release";
    case DynamicsScene::stretch:
      return "stretch";
    case DynamicsScene::relax:
      return "relax";
  }
  return "release";
}

std::string time_scheme_name(TimeScheme s) {
  return s == TimeScheme::bdf2 ? "bdf2" : "be";
}

DynamicsModel dynamics_model_from_string(const std::string& name) {
  if (name == "discrete") return DynamicsModel::discrete;
  if (name == "continuum") return DynamicsModel::continuum;
  throw InvalidParameter("model", "'" + name + "'", "one of discrete, continuum");
}

DynamicsScene dynamics_scene_from_string(const std::string& name) {
  if (name == "release") return DynamicsScene::release;
  if (name == "stretch") return DynamicsScene::stretch;
  if (name == "relax") return DynamicsScene::relax;
  throw InvalidParameter("scene", "'" + name + "'", "one of release, stretch, relax");
}

TimeScheme time_scheme_from_string(const std::string& name) {
  if (name == "be") return TimeScheme::backward_euler;
  if (name == "bdf2") return TimeScheme::bdf2;
  throw InvalidParameter("time scheme", "'" + name + "'", "one of be, bdf2");
}

void DynamicsSceneOptions::validate() const {
  const bool discrete = model == DynamicsModel::discrete;
  if (scheme == TimeScheme::bdf2 && !discrete)
    throw InvalidParameter("time scheme", "bdf2",
                           "be for the continuum model (bdf2 is implemented for the discrete "
                           "model only; the continuum step is backward Euler)");
  if (scene == DynamicsScene::relax && discrete)
    throw InvalidParameter("scene", "relax",
                           "release or stretch for the discrete model (relax is the Helfrich "
                           "relaxation of the continuum model)");
  require_finite_in_range("time step dt", "s", dt_s, 0, kUnbounded);
  require_finite_in_range("duration", "s", duration_s, 0, kUnbounded);
  if (dt_s > duration_s)
    throw InvalidParameter("time step dt", format_number(dt_s),
                           "at most the duration " + format_number(duration_s) + " s", "s");
  require_finite_in_range("membrane viscosity", "pN s/um", membrane_viscosity_pN_s_per_um, 0,
                          kUnbounded);
  require_finite_in_range("dilatational ratio eta_d/eta_m", "", dilatational_ratio, 0, kUnbounded,
                          Ends::closed_open);
  const double force_max = discrete ? kMaxDiscreteForce_pN : kMaxContinuumForce_pN;
  require_finite_in_range(discrete ? "force (discrete model)" : "force (continuum model)", "pN",
                          force_pN, 0, force_max,
                          scene == DynamicsScene::relax ? Ends::closed_closed : Ends::open_closed);
  require_finite_in_range("step tolerance", "pN/s", tolerance_pN_per_s, 0, kUnbounded,
                          Ends::closed_open);
  require_finite_in_range("regulariser (fraction of the p=2 law)", "", regulariser, 0, 1);
  require_finite_in_range("normal drag", "pN s/um^3", normal_drag_pN_s_per_um3, 0, kUnbounded);
  require_integer_in_range("vertices", vertices, 100, 40000);
  require_integer_in_range("elements", elements, kMinContinuumElements, kMaxContinuumElements);
  require_integer_in_range("max halvings", max_halvings, 0, 20);
  require_integer_in_range("step iterations", step_iterations, 0, 100000000);
  network.validate();
}

double DynamicsSceneOptions::step_tolerance_pN_per_s() const {
  if (tolerance_pN_per_s > 0) return tolerance_pN_per_s;
  return scene == DynamicsScene::relax ? 1e-5 : 1.0;
}

int DynamicsSceneOptions::sample_every() const {
  const long steps = std::lround(std::ceil(duration_s / dt_s - 1e-9));
  return static_cast<int>(std::max<long>(1, steps / 1000));
}

namespace {

/// The trajectory options of a scene.
TrajectoryOptions trajectory_options(const DynamicsSceneOptions& o) {
  TrajectoryOptions to;
  to.duration_s = o.duration_s;
  to.dt_s = o.dt_s;
  to.max_halvings = o.max_halvings;
  to.sample_every = o.sample_every();
  return to;
}

void run_discrete(const DynamicsSceneOptions& o, const ProgressSink& progress,
                  DynamicsSceneResult& out) {
  const DynamicsScene sc = o.scene;
  RestShapeOptions ro;
  ro.target_vertices = o.vertices;
  report(progress, "building the rest network (N ~ " + std::to_string(o.vertices) + ")");
  const TriMesh mesh = make_rest_shape(ro);
  const Network net = build_network(mesh, o.network);
  out.faces = net.topo.faces;
  out.vertices = net.topo.num_vertices;
  StretchOptions so;
  so.minimiser.force_tolerance = 1e-5;
  so.minimiser.cancel = o.cancel;
  Positions x0 = net.rest;
  ConstraintMultipliers l0;
  const StretchPoint rest = solve_equilibrium(net, 0.0, x0, l0, so, progress);
  Positions xf = x0;
  ConstraintMultipliers lf = l0;
  const StretchPoint loaded = solve_equilibrium(net, o.force_pN, xf, lf, so, progress);
  out.static_converged = rest.converged && loaded.converged;
  out.static_status = rest.converged ? to_string(loaded.status) : to_string(rest.status);
  out.static_residual_pN = std::max(rest.residual_pN, loaded.residual_pN);
  out.lambda_inf = rest.axial_um / rest.transverse_um;
  out.rest_axial_um = rest.axial_um;
  out.loaded_axial_um = loaded.axial_um;
  const StretchPoint& end = sc == DynamicsScene::release ? rest : loaded;
  out.static_axial_um = end.axial_um;
  out.static_transverse_um = end.transverse_um;
  if (!out.static_converged) return;
  DynamicsState start =
      sc == DynamicsScene::release ? DynamicsState{xf, lf} : DynamicsState{x0, l0};
  out.force_dynamics_pN = sc == DynamicsScene::release ? 0.0 : o.force_pN;
  DiscreteDynamicsOptions dop;
  dop.shear_viscosity_pN_s_per_um = o.membrane_viscosity_pN_s_per_um;
  dop.tolerance_pN_per_s = o.step_tolerance_pN_per_s();
  if (o.step_iterations > 0) dop.max_iterations = o.step_iterations;
  dop.scheme = o.scheme;
  dop.validate();
  const double f = out.force_dynamics_pN;
  out.trajectory = run_trajectory(
      [&](double h, DynamicsState& s) {
        throw_if_cancelled(o.cancel);
        return discrete_dynamics_step(net, f, h, s, dop);
      },
      [&](const DynamicsState& s) { return measure_discrete(net, f, s); }, start,
      trajectory_options(o), progress);
}

void run_continuum(const DynamicsSceneOptions& o, const ProgressSink& progress,
                   DynamicsSceneResult& out) {
  const DynamicsScene sc = o.scene;
  const TriMesh mesh = make_continuum_mesh(o.elements);
  const NetworkParameters& np = o.network;
  ContinuumParameters cp;
  cp.bending = np.bending;
  cp.tweezers = np.tweezers;
  const bool relax = sc == DynamicsScene::relax;
  // Relax: Helfrich only, with the in-plane law scaled by the regulariser as the static
  // `rbc relax` regulariser (continuum/relax.hpp) to keep the mesh from sliding tangentially.
  const IsotropicMembraneLaw law = make_membrane_law(np.wlc, np.steric, o.order);
  const ContinuumModel model =
      build_continuum_model(mesh, relax ? scaled_law(law, o.regulariser) : law, cp);
  out.faces = model.topo.faces;
  out.vertices = static_cast<int>(model.rest.cols());
  out.elements = model.num_elements();
  out.law = model.law.name;
  report(progress, "continuum mesh: " + std::to_string(out.vertices) + " vertices, " +
                       std::to_string(out.elements) + " elements, law " + model.law.name);
  ContinuumOptions co;
  co.cancel = o.cancel;
  DynamicsState start{model.rest, {}};
  if (!relax) {
    const auto pts = run_continuum_stretch(model, {0.0, o.force_pN}, co, progress);
    out.static_converged = pts[0].converged && pts[1].converged;
    out.static_status = pts[0].converged ? to_string(pts[1].status) : to_string(pts[0].status);
    out.static_residual_pN = std::max(pts[0].residual_pN, pts[1].residual_pN);
    out.lambda_inf = pts[0].axial_um / pts[0].transverse_um;
    out.rest_axial_um = pts[0].axial_um;
    out.loaded_axial_um = pts[1].axial_um;
    const auto& end = sc == DynamicsScene::release ? pts[0] : pts[1];
    out.static_axial_um = end.axial_um;
    out.static_transverse_um = end.transverse_um;
    if (!out.static_converged) return;
    start = sc == DynamicsScene::release ? DynamicsState{pts[1].x, pts[1].multipliers}
                                         : DynamicsState{pts[0].x, pts[0].multipliers};
    out.force_dynamics_pN = sc == DynamicsScene::release ? 0.0 : o.force_pN;
  }
  ContinuumDynamicsOptions dop;
  dop.shear_viscosity_pN_s_per_um = o.membrane_viscosity_pN_s_per_um;
  dop.dilatational_ratio = o.dilatational_ratio;
  dop.tolerance_pN_per_s = o.step_tolerance_pN_per_s();
  if (o.step_iterations > 0) dop.max_iterations = o.step_iterations;
  if (relax) dop.normal_drag_pN_s_per_um3 = o.normal_drag_pN_s_per_um3;
  ContinuumDynamics dyn(model, dop);
  const double f = out.force_dynamics_pN;
  out.trajectory = run_trajectory(
      [&](double h, DynamicsState& s) {
        throw_if_cancelled(o.cancel);
        return dyn.step(f, h, s);
      },
      [&](const DynamicsState& s) { return dyn.measure(f, s); }, start, trajectory_options(o),
      progress);
  if (relax && !out.trajectory.snapshots.empty()) {
    out.relax_disc_before_um = measure_disc(out.trajectory.snapshots.front()).diameter_um;
    out.relax_end = measure_disc(out.trajectory.snapshots.back());
    out.relax_disc_after_um = out.relax_end.diameter_um;
    // The static relaxation the trajectory should end at (same mesh, bending, regulariser).
    NewtonOptions no;
    no.max_iterations = 400;
    no.cancel = o.cancel;
    report(progress, "static Helfrich relaxation for comparison");
    const RelaxResult st =
        relax_helfrich(mesh, cp.bending, scaled_law(law, o.regulariser), no, progress);
    out.relax_static = st.after;
    out.relax_static_converged = st.solve.converged();
  }
}

/// Release: the recovery fit of the trajectory and Hochmuth's curve.
void fit_release(const DynamicsSceneOptions& o, const ProgressSink& progress,
                 DynamicsSceneResult& r) {
  std::vector<double> t, lam;
  for (const auto& s : r.trajectory.samples) {
    t.push_back(s.t_s);
    lam.push_back(s.axial_um / s.transverse_um);
  }
  r.recovery = fit_recovery(t, lam, r.lambda_inf);
  if (!r.recovery.valid)
    report(progress, "recovery fit invalid: " + std::to_string(r.recovery.points) +
                         " samples in the window (3 needed): use a smaller --dt");
  // Hochmuth's curve (his geometry was a pipette extension, not the tweezers').
  try {
    const std::string dir = o.data_dir.empty() ? default_data_directory() : o.data_dir;
    const CsvTable h = read_csv(dir + "/hochmuth1979_recovery.csv");
    std::vector<double> ht, hl;
    for (const auto& row : h.rows) {
      ht.push_back(row[0]);
      hl.push_back(row[1]);
    }
    r.hochmuth = fit_recovery_free_limit(ht, hl);
    r.hochmuth_read = true;
  } catch (const std::runtime_error& e) {
    report(progress, std::string("Hochmuth data not read: ") + e.what());
  }
}

/// The fluids' share of the dissipation for this scene (estimates; not modelled in-plane).
/// In-plane scenes: the cytosol (6 mPa s, paper Table 2) and the outer medium (~1 mPa s)
/// dissipate ~ eta_fluid R / eta_m of the membrane's (MODEL.md section 6; R = D_A(0)/2), and
/// each bead (Mills et al. 2004: 4.12 um silica spheres, a = 2.06 um, in the outer medium)
/// adds Stokes drag 6 pi eta_out a = 0.039 pN s/um at half the D_A rate, i.e. zeta_b/2 on
/// D_A, against the cell's own zeta_cell = k_eff eta_m/mu with k_eff = F/(D_A(F) - D_A(0)).
/// Relax (qualitative): the fluids' normal drag zeta ~ 2 (eta_cyt + eta_out) q with
/// q ~ 2 pi/25 um is modelled, but the shape change also needs tangential flow, resisted by
/// eta_m, which sets the pace at eta_m = 0.7 pN s/um (tests/app/test_cli_dynamics.cpp).
nlohmann::json fluid_estimate(const DynamicsSceneOptions& o, const DynamicsSceneResult& r) {
  constexpr double kPi = 3.14159265358979323846;
  constexpr double eta_cyt = 6e-3, eta_out = 1e-3;  // pN s/um^2 (= Pa s)
  constexpr double bead_radius_um = 2.06;
  nlohmann::json f = {{"cytosol_viscosity_pN_s_per_um2", eta_cyt},
                      {"outer_viscosity_pN_s_per_um2", eta_out}};
  if (o.scene == DynamicsScene::relax) {
    f["modelled"] = "normal drag " + format_number(o.normal_drag_pN_s_per_um3) + " pN s/um^3";
    f["estimate_of_normal_drag_pN_s_per_um3"] = 2 * (eta_cyt + eta_out) * 2 * kPi / 25.0;
    f["note"] =
        "qualitative: the fluids' normal drag is the Stokes estimate 2 (eta_cyt + eta_out) q "
        "of one mode, q ~ 2 pi / 25 um; the shape change also needs tangential flow, which the "
        "membrane viscosity resists, and at eta_m = 0.7 pN s/um that sets the pace (measured "
        "at 400 elements over 0.1 s: 10 x eta_m moves the rim 7 x less, 10 x the drag 1.2 x "
        "less); the in-plane regulariser is a mesh device that creeps on eta_m/(reg mu)";
    return f;
  }
  const double eta = o.membrane_viscosity_pN_s_per_um;
  const double radius = 0.5 * r.rest_axial_um;
  const double bead_drag = 6 * kPi * eta_out * bead_radius_um;
  const double k_eff = o.force_pN / (r.loaded_axial_um - r.rest_axial_um);
  const double cell_drag = k_eff * eta / r.shear_modulus_pN_per_um;
  f["modelled"] = "no (membrane viscosity only)";
  f["cytosol_share"] = eta_cyt * radius / eta;
  f["outer_share"] = eta_out * radius / eta;
  f["bead_drag_pN_s_per_um"] = bead_drag;
  f["cell_axial_drag_pN_s_per_um"] = cell_drag;
  f["bead_share"] = 0.5 * bead_drag / cell_drag;
  f["note"] =
      "estimates of dissipation relative to the membrane's: eta_fluid R / eta_m for the fluids "
      "(R = D_A(0)/2), (6 pi eta_out a)/2 over k_eff eta_m/mu for the two beads (a = 2.06 um)";
  return f;
}

}  // namespace

DynamicsSceneResult run_dynamics_scene(const DynamicsSceneOptions& options,
                                       const ProgressSink& progress) {
  options.validate();
  DynamicsSceneResult r;
  const LinearModuli mod = closed_form_moduli(options.network.wlc, options.network.steric);
  r.shear_modulus_pN_per_um = mod.mu_pN_per_um;
  r.kelvin_voigt_time_s = options.membrane_viscosity_pN_s_per_um / mod.mu_pN_per_um;
  if (options.model == DynamicsModel::discrete)
    run_discrete(options, progress, r);
  else
    run_continuum(options, progress, r);
  if (r.converged() && options.scene == DynamicsScene::release) fit_release(options, progress, r);
  return r;
}

nlohmann::json dynamics_summary_json(const DynamicsSceneOptions& o, const DynamicsSceneResult& r) {
  const bool discrete = o.model == DynamicsModel::discrete;
  const double eta = o.membrane_viscosity_pN_s_per_um;
  const TrajectoryResult& traj = r.trajectory;
  nlohmann::json j = {
      {"model", to_string(o.model)},
      {"scene", to_string(o.scene)},
      {"force_pN", o.force_pN},
      {"membrane_viscosity_pN_s_per_um", eta},
      {"dilatational_viscosity_pN_s_per_um", discrete ? 2.0 * eta : o.dilatational_ratio * eta},
      {"scheme", time_scheme_name(o.scheme)},
      {"dt_s", o.dt_s},
      {"step_tolerance_pN_per_s", o.step_tolerance_pN_per_s()},
      {"duration_s", o.duration_s},
      {"vertices", r.vertices},
      {"shear_modulus_pN_per_um", r.shear_modulus_pN_per_um},
      {"kelvin_voigt_time_s", r.kelvin_voigt_time_s},
      {"converged", traj.converged},
      {"status", traj.status},
      {"halved_steps", traj.halved_steps},
      {"wall_s", traj.wall_s},
      {"fluids", fluid_estimate(o, r)}};
  if (!discrete) j["elements"] = r.elements;
  if (o.scene == DynamicsScene::release) {
    const RecoveryFit& fit = r.recovery;
    j["recovery_fit_valid"] = fit.valid;
    j["lambda_inf"] = r.lambda_inf;
    j["recovery_time_s"] = fit.recovery_time_s;
    j["recovery_time_err_s"] = fit.recovery_time_err_s;
    j["fit_window_s"] = {fit.window_start_s, fit.window_end_s};
    j["fit_window_rule"] = "t = 0 until m(t) first falls below 0.1 m(0)";
    j["fit_points"] = fit.points;
    j["geometry_factor"] = fit.recovery_time_s / r.kelvin_voigt_time_s;
    if (r.hochmuth_read) {
      j["hochmuth_recovery_time_s"] = r.hochmuth.recovery_time_s;
      j["hochmuth_lambda_inf"] = r.hochmuth.lambda_inf;
      // Without fluids the only time scale is eta/mu: t_c is proportional to eta_m.
      if (fit.valid && fit.recovery_time_s > 0)
        j["eta_matching_hochmuth_pN_s_per_um"] =
            eta * r.hochmuth.recovery_time_s / fit.recovery_time_s;
    }
  } else if (o.scene == DynamicsScene::stretch) {
    j["static_axial_um"] = r.static_axial_um;
    j["static_transverse_um"] = r.static_transverse_um;
    if (!traj.samples.empty()) {
      j["final_axial_relative_to_static"] = traj.samples.back().axial_um / r.static_axial_um - 1;
      j["final_transverse_relative_to_static"] =
          traj.samples.back().transverse_um / r.static_transverse_um - 1;
    }
  } else {
    j["normal_drag_pN_s_per_um3"] = o.normal_drag_pN_s_per_um3;
    j["disc_diameter_before_um"] = r.relax_disc_before_um;
    j["disc_diameter_after_um"] = r.relax_disc_after_um;
    j["thickness_centre_after_um"] = r.relax_end.thickness_centre_um;
    j["thickness_rim_after_um"] = r.relax_end.thickness_rim_um;
    j["regulariser"] = o.regulariser;
    j["static_relax_converged"] = r.relax_static_converged;
    j["static_disc_diameter_um"] = r.relax_static.diameter_um;
    j["static_thickness_centre_um"] = r.relax_static.thickness_centre_um;
    j["static_thickness_rim_um"] = r.relax_static.thickness_rim_um;
  }
  nlohmann::json series = nlohmann::json::array();
  const size_t stride = std::max<size_t>(1, traj.samples.size() / 200);
  for (size_t k = 0; k < traj.samples.size(); k += stride) {
    const auto& s = traj.samples[k];
    series.push_back({{"t_s", s.t_s},
                      {"axial_um", s.axial_um},
                      {"transverse_um", s.transverse_um},
                      {"energy_pNum", s.energy_pNum}});
  }
  j["samples"] = series;
  return j;
}

}  // namespace rbc
