// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc dynamics`: overdamped dynamics of either model (MODEL.md section 6) by backward Euler
// minimising movements: shape recovery after release (Hochmuth, Worthy & Evans 1979), the
// time course of a stretch (paper Fig. 6), and the Helfrich relaxation (paper Fig. 5,
// continuum only). Time series as CSV/JSON, shapes as one HDF5 + XDMF time series, and a
// PNG of the diameters against time.
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/run_config.hpp"
#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/render.hpp"
#include "compare/experiment.hpp"
#include "compare/plot.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/dynamics.hpp"
#include "continuum/relax.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"
#include "core/rest_shape.hpp"
#include "core/validation.hpp"
#include "discrete/dynamics.hpp"
#include "discrete/stretch.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/moduli.hpp"

namespace rbc::app {

namespace {

enum class Scene { release, stretch, relax };

struct DynamicsCli {
  std::string model = "continuum";
  std::string scene = "release";
  std::string scheme = "be";  ///< be (backward Euler) | bdf2 (discrete only)
  double force_pN = 88.0;
  double eta_pN_s_per_um = 0.7;  // Hochmuth 1979 range 0.6-0.8 with mu ~ 6 uN/m
  double dilatational_ratio = 2.0;
  double duration_s = 0.5, dt_s = 1e-3;
  /// Step force tolerance per unit dt (pN/s); 0 = the scene's default (step_tolerance).
  double tolerance_pN_per_s = 0.0;
  double normal_drag = 3.5e-3;  // pN s/um^3, relax scene only (see continuum/dynamics.hpp)
  /// Relax: in-plane mesh regulariser, fraction of the p = 2 law (as `rbc relax --regulariser`).
  double regulariser = 0.01;
  int vertices = 500, elements = 1000;
  std::string order = "2";
  int frames = 100;
  int max_halvings = 4;
  /// Solver iterations per step: L-BFGS per multiplier update (discrete), Newton (continuum).
  /// 0 = the library defaults (20,000 L-BFGS iterations per update; 50 Newton iterations).
  int step_iterations = 0;
  std::string out;
  bool json = false, quiet = false, overwrite = false;
  bool picture = true;  ///< --out: cells.png of the first and the last frame (--no-picture)
};

Scene scene_from(const std::string& s) {
  if (s == "release") return Scene::release;
  if (s == "stretch") return Scene::stretch;
  if (s == "relax") return Scene::relax;
  throw std::invalid_argument("--scene '" + s + "' is not one of release, stretch, relax");
}

void validate(const DynamicsCli& o) {
  if (o.model != "discrete" && o.model != "continuum")
    throw std::invalid_argument("--model '" + o.model + "' is not one of discrete, continuum");
  const Scene sc = scene_from(o.scene);
  if (o.scheme != "be" && o.scheme != "bdf2")
    throw std::invalid_argument("--scheme '" + o.scheme + "' is not one of be, bdf2");
  if (o.scheme == "bdf2" && o.model != "discrete")
    throw std::invalid_argument(
        "--scheme bdf2 is implemented for --model discrete only; the continuum step is "
        "backward Euler");
  if (sc == Scene::relax && o.model == "discrete")
    throw std::invalid_argument(
        "--scene relax is the Helfrich relaxation of the continuum model; use --model continuum");
  if (!(o.dt_s > 0) || !std::isfinite(o.dt_s))
    throw std::invalid_argument("--dt must be finite and > 0 s, got " + format_number(o.dt_s));
  if (!(o.duration_s > 0) || !std::isfinite(o.duration_s))
    throw std::invalid_argument("--duration must be finite and > 0 s, got " +
                                format_number(o.duration_s));
  if (o.dt_s > o.duration_s)
    throw std::invalid_argument("--dt " + format_number(o.dt_s) + " s must not exceed --duration " +
                                format_number(o.duration_s) + " s");
  if (!(o.eta_pN_s_per_um > 0) || !std::isfinite(o.eta_pN_s_per_um))
    throw std::invalid_argument("--membrane-viscosity must be finite and > 0 pN s/um, got " +
                                format_number(o.eta_pN_s_per_um));
  if (!(o.dilatational_ratio >= 0) || !std::isfinite(o.dilatational_ratio))
    throw std::invalid_argument("--dilatational-ratio must be >= 0, got " +
                                format_number(o.dilatational_ratio));
  const double force_max = o.model == "discrete" ? kMaxDiscreteForce_pN : kMaxContinuumForce_pN;
  if (!(o.force_pN >= 0) || !(o.force_pN <= force_max))
    throw std::invalid_argument("--force must be finite and in [0, " + format_number(force_max) +
                                "] pN for --model " + o.model + ", got " +
                                format_number(o.force_pN));
  if ((sc == Scene::release || sc == Scene::stretch) && !(o.force_pN > 0))
    throw std::invalid_argument("--force must be > 0 pN for --scene " + o.scene + ", got " +
                                format_number(o.force_pN));
  if (!(o.tolerance_pN_per_s >= 0) || !std::isfinite(o.tolerance_pN_per_s))
    throw std::invalid_argument("--tolerance must be finite and >= 0 pN/s (0 = default), got " +
                                format_number(o.tolerance_pN_per_s));
  if (!(o.regulariser > 0) || !(o.regulariser <= 1))
    throw std::invalid_argument("--regulariser must be in (0, 1], got " +
                                format_number(o.regulariser));
  if (!(o.normal_drag > 0))
    throw std::invalid_argument("--normal-drag must be > 0 pN s/um^3, got " +
                                format_number(o.normal_drag));
  if (o.vertices < 100 || o.vertices > 40000)
    throw std::invalid_argument("--vertices " + format_number(o.vertices) +
                                " is out of range; expected 100 to 40000");
  if (o.elements < kMinContinuumElements || o.elements > kMaxContinuumElements)
    throw std::invalid_argument(
        "--elements " + format_number(o.elements) + " is out of range; expected " +
        std::to_string(kMinContinuumElements) + " to " + std::to_string(kMaxContinuumElements));
  if (o.frames < 1)
    throw std::invalid_argument("--frames must be >= 1, got " + format_number(o.frames));
  if (o.step_iterations < 0)
    throw std::invalid_argument("--step-iterations must be >= 0 (0 = default), got " +
                                std::to_string(o.step_iterations));
  if (o.max_halvings < 0 || o.max_halvings > 20)
    throw std::invalid_argument("--max-halvings must be in [0, 20], got " +
                                format_number(o.max_halvings));
  wlc_expansion_from_string(o.order);
}

/// The step force tolerance per unit dt (pN/s): --tolerance, or by default 1 pN/s for the
/// in-plane scenes (elastic forces ~ pN: 1e-3 pN at dt = 1 ms) and 1e-5 pN/s for relax
/// (bending forces ~ 1e-2 pN per vertex at 400 elements; a step of 1 s is solved to 1e-5 pN).
double step_tolerance(const DynamicsCli& o, Scene sc) {
  if (o.tolerance_pN_per_s > 0) return o.tolerance_pN_per_s;
  return sc == Scene::relax ? 1e-5 : 1.0;
}

/// Everything a scene produces, independent of the model.
struct SceneRun {
  TrajectoryResult traj;
  Faces faces;
  double lambda_inf = 1.0;                               ///< D_A/D_T at the zero-force equilibrium
  double static_axial_um = 0, static_transverse_um = 0;  ///< static end state (stretch/release)
  double rest_axial_um = 0, loaded_axial_um = 0;         ///< static D_A at 0 and at F
  double force_dynamics_pN = 0;
  bool static_converged = true;
  std::string static_status;
  double static_residual_pN = 0;
  int vertices = 0, elements = 0;
  double relax_disc_before_um = 0, relax_disc_after_um = 0;
  DiscShape relax_static;  ///< the static relaxation (relax_helfrich) at the same regulariser
  bool relax_static_converged = false;
};

SceneRun run_discrete_scene(const DynamicsCli& o, Scene sc, const ProgressSink& progress,
                            int sample_every) {
  SceneRun out;
  RestShapeOptions ro;
  ro.target_vertices = o.vertices;
  report(progress, "building the rest network (N ~ " + std::to_string(o.vertices) + ")");
  const TriMesh mesh = make_rest_shape(ro);
  const Network net = build_network(mesh, NetworkParameters{});
  out.faces = net.topo.faces;
  out.vertices = net.topo.num_vertices;
  StretchOptions so;
  so.minimiser.force_tolerance = 1e-5;
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
  const StretchPoint& end = sc == Scene::release ? rest : loaded;
  out.static_axial_um = end.axial_um;
  out.static_transverse_um = end.transverse_um;
  if (!out.static_converged) return out;
  DynamicsState start = sc == Scene::release ? DynamicsState{xf, lf} : DynamicsState{x0, l0};
  out.force_dynamics_pN = sc == Scene::release ? 0.0 : o.force_pN;
  DiscreteDynamicsOptions dop;
  dop.shear_viscosity_pN_s_per_um = o.eta_pN_s_per_um;
  dop.tolerance_pN_per_s = step_tolerance(o, sc);
  if (o.step_iterations > 0) dop.max_iterations = o.step_iterations;
  dop.scheme = o.scheme == "bdf2" ? TimeScheme::bdf2 : TimeScheme::backward_euler;
  dop.validate();
  TrajectoryOptions to;
  to.duration_s = o.duration_s;
  to.dt_s = o.dt_s;
  to.max_halvings = o.max_halvings;
  to.sample_every = sample_every;
  const double f = out.force_dynamics_pN;
  out.traj = run_trajectory(
      [&](double h, DynamicsState& s) { return discrete_dynamics_step(net, f, h, s, dop); },
      [&](const DynamicsState& s) { return measure_discrete(net, f, s); }, start, to, progress);
  return out;
}

SceneRun run_continuum_scene(const DynamicsCli& o, Scene sc, const ProgressSink& progress,
                             int sample_every) {
  SceneRun out;
  const TriMesh mesh = make_continuum_mesh(o.elements);
  const NetworkParameters np;
  ContinuumParameters cp;
  cp.bending = np.bending;
  cp.tweezers = np.tweezers;
  const bool relax = sc == Scene::relax;
  // Relax: Helfrich only, with the in-plane law scaled by --regulariser as the static `rbc relax`
  // regulariser (continuum/relax.hpp) to keep the mesh from sliding tangentially.
  const IsotropicMembraneLaw law =
      make_membrane_law(np.wlc, np.steric, wlc_expansion_from_string(o.order));
  const ContinuumModel model =
      build_continuum_model(mesh, relax ? scaled_law(law, o.regulariser) : law, cp);
  out.faces = model.topo.faces;
  out.vertices = static_cast<int>(model.rest.cols());
  out.elements = model.num_elements();
  report(progress, "continuum mesh: " + std::to_string(out.vertices) + " vertices, " +
                       std::to_string(out.elements) + " elements, law " + model.law.name);
  ContinuumOptions co;
  DynamicsState start{model.rest, {}};
  if (!relax) {
    const auto pts = run_continuum_stretch(model, {0.0, o.force_pN}, co, progress);
    out.static_converged = pts[0].converged && pts[1].converged;
    out.static_status = pts[0].converged ? to_string(pts[1].status) : to_string(pts[0].status);
    out.static_residual_pN = std::max(pts[0].residual_pN, pts[1].residual_pN);
    out.lambda_inf = pts[0].axial_um / pts[0].transverse_um;
    out.rest_axial_um = pts[0].axial_um;
    out.loaded_axial_um = pts[1].axial_um;
    const auto& end = sc == Scene::release ? pts[0] : pts[1];
    out.static_axial_um = end.axial_um;
    out.static_transverse_um = end.transverse_um;
    if (!out.static_converged) return out;
    start = sc == Scene::release ? DynamicsState{pts[1].x, pts[1].multipliers}
                                 : DynamicsState{pts[0].x, pts[0].multipliers};
    out.force_dynamics_pN = sc == Scene::release ? 0.0 : o.force_pN;
  }
  ContinuumDynamicsOptions dop;
  dop.shear_viscosity_pN_s_per_um = o.eta_pN_s_per_um;
  dop.dilatational_ratio = o.dilatational_ratio;
  dop.tolerance_pN_per_s = step_tolerance(o, sc);
  if (o.step_iterations > 0) dop.max_iterations = o.step_iterations;
  if (relax) dop.normal_drag_pN_s_per_um3 = o.normal_drag;
  ContinuumDynamics dyn(model, dop);
  TrajectoryOptions to;
  to.duration_s = o.duration_s;
  to.dt_s = o.dt_s;
  to.max_halvings = o.max_halvings;
  to.sample_every = sample_every;
  const double f = out.force_dynamics_pN;
  out.traj = run_trajectory([&](double h, DynamicsState& s) { return dyn.step(f, h, s); },
                            [&](const DynamicsState& s) { return dyn.measure(f, s); }, start, to,
                            progress);
  if (relax && !out.traj.snapshots.empty()) {
    out.relax_disc_before_um = measure_disc(out.traj.snapshots.front()).diameter_um;
    out.relax_disc_after_um = measure_disc(out.traj.snapshots.back()).diameter_um;
    // The static relaxation the trajectory should end at (same mesh, bending, regulariser).
    NewtonOptions no;
    no.max_iterations = 400;
    report(progress, "static Helfrich relaxation for comparison");
    const RelaxResult st =
        relax_helfrich(mesh, cp.bending, scaled_law(law, o.regulariser), no, progress);
    out.relax_static = st.after;
    out.relax_static_converged = st.solve.converged();
  }
  return out;
}

/// One HDF5 file with every frame and an XDMF temporal collection over it.
void write_time_series(const std::string& dir, const SceneRun& r, int frame_every) {
  const std::string h5_path = dir + "/dynamics.h5";
  TempFile tmp(h5_path);  // removed on every path that does not commit it
  std::vector<size_t> frames;
  for (size_t k = 0; k < r.traj.snapshots.size(); ++k)
    if (k % frame_every == 0 || k + 1 == r.traj.snapshots.size()) frames.push_back(k);
  const auto nf = static_cast<hsize_t>(r.faces.cols());
  const auto nv = static_cast<hsize_t>(r.traj.snapshots.front().cols());
  {
    H5File f = H5File::create(tmp.path(), h5_path);
    f.write("/mesh/faces", r.faces.data(), nf, 3);
    std::vector<double> times;
    for (size_t k : frames) {
      std::ostringstream name;
      name << "/frames/" << std::setw(6) << std::setfill('0') << k << "/positions_um";
      f.write(name.str(), r.traj.snapshots[k].data(), nv, 3);
      times.push_back(r.traj.samples[k].t_s);
    }
    f.write("/time_s", times.data(), times.size(), 1);
    f.close();
  }
  tmp.commit();
  std::ostringstream x;
  x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
    << "  <Grid Name=\"membrane\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (size_t k : frames) {
    std::ostringstream id;
    id << std::setw(6) << std::setfill('0') << k;
    x << "   <Grid Name=\"t" << id.str() << "\" GridType=\"Uniform\">\n"
      << "    <Time Value=\"" << std::setprecision(10) << r.traj.samples[k].t_s << "\"/>\n"
      << "    <Topology TopologyType=\"Triangle\" NumberOfElements=\"" << nf << "\">\n"
      << "     <DataItem Dimensions=\"" << nf
      << " 3\" NumberType=\"Int\" Format=\"HDF\">dynamics.h5:/mesh/faces</DataItem>\n"
      << "    </Topology>\n    <Geometry GeometryType=\"XYZ\">\n"
      << "     <DataItem Dimensions=\"" << nv
      << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">dynamics.h5:/frames/" << id.str()
      << "/positions_um</DataItem>\n    </Geometry>\n   </Grid>\n";
  }
  x << "  </Grid>\n </Domain>\n</Xdmf>\n";
  write_text_atomic(dir + "/dynamics.xdmf", x.str());
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
nlohmann::json fluid_estimate(const DynamicsCli& o, Scene sc, const SceneRun& r,
                              double mu_pN_per_um) {
  constexpr double kPi = 3.14159265358979323846;
  constexpr double eta_cyt = 6e-3, eta_out = 1e-3;  // pN s/um^2 (= Pa s)
  constexpr double bead_radius_um = 2.06;
  nlohmann::json f = {{"cytosol_viscosity_pN_s_per_um2", eta_cyt},
                      {"outer_viscosity_pN_s_per_um2", eta_out}};
  if (sc == Scene::relax) {
    f["modelled"] = "normal drag " + format_number(o.normal_drag) + " pN s/um^3";
    f["estimate_of_normal_drag_pN_s_per_um3"] = 2 * (eta_cyt + eta_out) * 2 * kPi / 25.0;
    f["note"] =
        "qualitative: the fluids' normal drag is the Stokes estimate 2 (eta_cyt + eta_out) q "
        "of one mode, q ~ 2 pi / 25 um; the shape change also needs tangential flow, which the "
        "membrane viscosity resists, and at eta_m = 0.7 pN s/um that sets the pace (measured "
        "at 400 elements over 0.1 s: 10 x eta_m moves the rim 7 x less, 10 x the drag 1.2 x "
        "less); the in-plane regulariser is a mesh device that creeps on eta_m/(reg mu)";
    return f;
  }
  const double radius = 0.5 * r.rest_axial_um;
  const double bead_drag = 6 * kPi * eta_out * bead_radius_um;
  const double k_eff = o.force_pN / (r.loaded_axial_um - r.rest_axial_um);
  const double cell_drag = k_eff * o.eta_pN_s_per_um / mu_pN_per_um;
  f["modelled"] = "no (membrane viscosity only)";
  f["cytosol_share"] = eta_cyt * radius / o.eta_pN_s_per_um;
  f["outer_share"] = eta_out * radius / o.eta_pN_s_per_um;
  f["bead_drag_pN_s_per_um"] = bead_drag;
  f["cell_axial_drag_pN_s_per_um"] = cell_drag;
  f["bead_share"] = 0.5 * bead_drag / cell_drag;
  f["note"] =
      "estimates of dissipation relative to the membrane's: eta_fluid R / eta_m for the fluids "
      "(R = D_A(0)/2), (6 pi eta_out a)/2 over k_eff eta_m/mu for the two beads (a = 2.06 um)";
  return f;
}

int run(const DynamicsCli& o) {
  validate(o);
  const Scene sc = scene_from(o.scene);
  if (!o.out.empty()) prepare_output_directory(o.out, o.overwrite);
  const ProgressSink progress = stderr_progress(o.quiet);
  const long steps = std::lround(std::ceil(o.duration_s / o.dt_s - 1e-9));
  const int sample_every = static_cast<int>(std::max<long>(1, steps / 1000));
  SceneRun r = o.model == "discrete" ? run_discrete_scene(o, sc, progress, sample_every)
                                     : run_continuum_scene(o, sc, progress, sample_every);
  if (!r.static_converged) {
    std::cerr << "rbc: error: the static equilibrium did not converge (" << r.static_status
              << "): largest vertex force residual " << std::scientific << r.static_residual_pN
              << " pN\n";
    return 1;
  }
  if (!r.traj.converged) {  // nothing written: a trajectory that stops early is no result
    std::cerr << "rbc: error: " << r.traj.status << "\n";
    return 1;
  }
  const LinearModuli mod = closed_form_moduli(WlcParameters{}, StericParameters{});
  const double tc_kv = o.eta_pN_s_per_um / mod.mu_pN_per_um;
  // Hochmuth measure and fit (release).
  std::vector<double> t, lam;
  for (const auto& s : r.traj.samples) {
    t.push_back(s.t_s);
    lam.push_back(s.axial_um / s.transverse_um);
  }
  nlohmann::json j = {
      {"model", o.model},
      {"scene", o.scene},
      {"force_pN", o.force_pN},
      {"membrane_viscosity_pN_s_per_um", o.eta_pN_s_per_um},
      {"dilatational_viscosity_pN_s_per_um",
       o.model == "discrete" ? 2.0 * o.eta_pN_s_per_um : o.dilatational_ratio * o.eta_pN_s_per_um},
      {"scheme", o.scheme},
      {"dt_s", o.dt_s},
      {"step_tolerance_pN_per_s", step_tolerance(o, sc)},
      {"duration_s", o.duration_s},
      {"vertices", r.vertices},
      {"shear_modulus_pN_per_um", mod.mu_pN_per_um},
      {"kelvin_voigt_time_s", tc_kv},
      {"converged", r.traj.converged},
      {"status", r.traj.status},
      {"halved_steps", r.traj.halved_steps},
      {"wall_s", r.traj.wall_s},
      {"fluids", fluid_estimate(o, sc, r, mod.mu_pN_per_um)}};
  if (o.model == "continuum") j["elements"] = r.elements;
  if (sc == Scene::release) {
    const RecoveryFit fit = fit_recovery(t, lam, r.lambda_inf);
    if (!fit.valid)
      report(progress, "recovery fit invalid: " + std::to_string(fit.points) +
                           " samples in the window (3 needed): use a smaller --dt");
    j["recovery_fit_valid"] = fit.valid;
    j["lambda_inf"] = r.lambda_inf;
    j["recovery_time_s"] = fit.recovery_time_s;
    j["recovery_time_err_s"] = fit.recovery_time_err_s;
    j["fit_window_s"] = {fit.window_start_s, fit.window_end_s};
    j["fit_window_rule"] = "t = 0 until m(t) first falls below 0.1 m(0)";
    j["fit_points"] = fit.points;
    j["geometry_factor"] = fit.recovery_time_s / tc_kv;
    // Hochmuth's curve (his geometry was a pipette extension, not the tweezers').
    try {
      const CsvTable h = read_csv(default_data_directory() + "/hochmuth1979_recovery.csv");
      std::vector<double> ht, hl;
      for (const auto& row : h.rows) {
        ht.push_back(row[0]);
        hl.push_back(row[1]);
      }
      const RecoveryFit hf = fit_recovery_free_limit(ht, hl);
      j["hochmuth_recovery_time_s"] = hf.recovery_time_s;
      j["hochmuth_lambda_inf"] = hf.lambda_inf;
      // Without fluids the only time scale is eta/mu: t_c is proportional to eta_m.
      if (fit.valid && fit.recovery_time_s > 0)
        j["eta_matching_hochmuth_pN_s_per_um"] =
            o.eta_pN_s_per_um * hf.recovery_time_s / fit.recovery_time_s;
    } catch (const std::runtime_error& e) {
      report(progress, std::string("Hochmuth data not read: ") + e.what());
    }
  } else if (sc == Scene::stretch) {
    j["static_axial_um"] = r.static_axial_um;
    j["static_transverse_um"] = r.static_transverse_um;
    j["final_axial_relative_to_static"] = r.traj.samples.back().axial_um / r.static_axial_um - 1;
    j["final_transverse_relative_to_static"] =
        r.traj.samples.back().transverse_um / r.static_transverse_um - 1;
  } else {
    j["normal_drag_pN_s_per_um3"] = o.normal_drag;
    j["disc_diameter_before_um"] = r.relax_disc_before_um;
    j["disc_diameter_after_um"] = r.relax_disc_after_um;
    const DiscShape end = measure_disc(r.traj.snapshots.back());
    j["thickness_centre_after_um"] = end.thickness_centre_um;
    j["thickness_rim_after_um"] = end.thickness_rim_um;
    j["regulariser"] = o.regulariser;
    j["static_relax_converged"] = r.relax_static_converged;
    j["static_disc_diameter_um"] = r.relax_static.diameter_um;
    j["static_thickness_centre_um"] = r.relax_static.thickness_centre_um;
    j["static_thickness_rim_um"] = r.relax_static.thickness_rim_um;
  }
  CsvTable csv;
  csv.comments = {"rbc dynamics --model " + o.model + " --scene " + o.scene,
                  "units: time s, diameters um, energy pN*um; lambda = D_A/D_T"};
  csv.header = {"t_s",         "axial_um",   "transverse_um", "lambda",
                "energy_pNum", "area_drift", "volume_drift",  "iterations"};
  nlohmann::json series = nlohmann::json::array();
  for (size_t k = 0; k < r.traj.samples.size(); ++k) {
    const auto& s = r.traj.samples[k];
    csv.rows.push_back({s.t_s, s.axial_um, s.transverse_um, lam[k], s.energy_pNum, s.area_drift,
                        s.volume_drift, static_cast<double>(s.iterations)});
  }
  const size_t stride = std::max<size_t>(1, r.traj.samples.size() / 200);
  for (size_t k = 0; k < r.traj.samples.size(); k += stride) {
    const auto& s = r.traj.samples[k];
    series.push_back({{"t_s", s.t_s},
                      {"axial_um", s.axial_um},
                      {"transverse_um", s.transverse_um},
                      {"energy_pNum", s.energy_pNum}});
  }
  j["samples"] = series;
  if (!o.out.empty()) {
    write_csv(o.out + "/dynamics.csv", csv);
    write_time_series(o.out, r, std::max(1, static_cast<int>(r.traj.snapshots.size()) / o.frames));
    if (o.picture) {
      // cells.png: the first and the last frame (app/render.hpp); never fails the run.
      RenderRequest cells{{o.out + "/dynamics.xdmf"},
                          o.out + "/cells.png",
                          "",
                          "rbc dynamics: " + o.model + ", " + o.scene};
      const std::string why_not = draw_cells(cells);
      j[why_not.empty() ? "picture" : "picture_not_drawn"] =
          why_not.empty() ? "cells.png" : why_not;
      if (!why_not.empty()) report(progress, "no cells.png: " + why_not);
    }
    write_text_atomic(o.out + "/dynamics.json", j.dump(2) + "\n");
    PlotSpec p;
    p.title = "rbc dynamics: " + o.model + ", " + o.scene;
    p.xlabel = "time (s)";
    p.ylabel = "diameter (µm)";
    p.series.push_back({"D_{A}", "dynamics.csv", "1:2", "lines", "#1f77b4"});
    p.series.push_back({"D_{T}", "dynamics.csv", "1:3", "lines", "#d62728"});
    if (sc == Scene::release && j.contains("recovery_time_s")) {
      // Fitted exponential for lambda, drawn on the right axis.
      const RecoveryFit fit = fit_recovery(t, lam, r.lambda_inf);
      std::ostringstream fn;
      fn << "m(x) = " << fit.m0 << "*exp(-x/" << fit.recovery_time_s << ")";
      p.extra_commands.push_back(fn.str());
      p.extra_commands.push_back("set y2label '{/Symbol l} = D_{A}/D_{T}'");
      p.extra_commands.push_back("set y2tics");
      std::ostringstream plot2;
      plot2 << "linf = " << r.lambda_inf;
      p.extra_commands.push_back(plot2.str());
      p.series.push_back(
          {"{/Symbol l} (right axis)", "dynamics.csv", "1:4 axes x1y2", "lines", "#2ca02c"});
      std::ostringstream title;
      title << "fit t_{c} = " << std::setprecision(3) << fit.recovery_time_s << " s";
      p.series.push_back({title.str(), "dynamics.csv", "1:(linf*(1+m($1))/(1-m($1))) axes x1y2",
                          "lines", "#000000", 7, 2});
    }
    try {
      render_plot(p, o.out, "dynamics");
    } catch (const std::runtime_error& e) {
      report(progress, std::string("plot not rendered: ") + e.what());
    }
  }
  if (o.json) {
    std::cout << j.dump(2) << "\n";
  } else {
    std::cout << "# rbc dynamics: " << o.model << ", scene " << o.scene << ", eta_m "
              << o.eta_pN_s_per_um << " pN s/um, dt " << o.dt_s << " s, " << r.traj.samples.size()
              << " samples, wall " << std::setprecision(3) << r.traj.wall_s << " s\n";
    for (const char* k :
         {"recovery_time_s", "recovery_time_err_s", "geometry_factor", "kelvin_voigt_time_s",
          "hochmuth_recovery_time_s", "eta_matching_hochmuth_pN_s_per_um",
          "final_axial_relative_to_static", "disc_diameter_before_um", "disc_diameter_after_um"})
      if (j.contains(k))
        std::cout << k << " = " << std::setprecision(6) << j[k].get<double>() << "\n";
    const auto& last = r.traj.samples.back();
    std::cout << "final t = " << last.t_s << " s: D_A = " << last.axial_um
              << " um, D_T = " << last.transverse_um << " um\n";
  }
  return 0;
}

}  // namespace

void add_dynamics_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<DynamicsCli>();
  auto* cmd = app.add_subcommand(
      "dynamics", "Overdamped dynamics: recovery after release, time course of a stretch");
  add_config_option(cmd);
  cmd->add_option("--model", o->model, "discrete | continuum")->capture_default_str();
  cmd->add_option("--scene", o->scene,
                  "release (equilibrium at F, then F = 0) | stretch (F from t = 0) | relax "
                  "(Helfrich, continuum only)")
      ->capture_default_str();
  cmd->add_option("--scheme", o->scheme,
                  "time scheme: be (backward Euler, energy-monotone) | bdf2 (second order, "
                  "discrete only)")
      ->capture_default_str();
  cmd->add_option("--force", o->force_pN, "total bead force F (pN)")->capture_default_str();
  cmd->add_option("--membrane-viscosity", o->eta_pN_s_per_um,
                  "membrane shear viscosity eta_m (pN s/um = Pa s um)")
      ->capture_default_str();
  cmd->add_option("--dilatational-ratio", o->dilatational_ratio,
                  "continuum: eta_d / eta_m (the network's value is 2)")
      ->capture_default_str();
  cmd->add_option("--duration", o->duration_s, "simulated time T (s)")->capture_default_str();
  cmd->add_option("--dt", o->dt_s, "time step (s)")->capture_default_str();
  cmd->add_option("--tolerance", o->tolerance_pN_per_s,
                  "step force tolerance per unit dt (pN/s): tolerance = this x dt; 0 = 1 "
                  "(release, stretch) or 1e-5 (relax)")
      ->capture_default_str();
  cmd->add_option("--regulariser", o->regulariser,
                  "relax: in-plane mesh regulariser, fraction of the p=2 law, in (0, 1]")
      ->capture_default_str();
  cmd->add_option("--normal-drag", o->normal_drag,
                  "relax: normal drag of the fluids per area (pN s/um^3, qualitative)")
      ->capture_default_str();
  cmd->add_option("--vertices,-n", o->vertices, "discrete: network vertices")
      ->capture_default_str();
  cmd->add_option("--elements", o->elements, "continuum: triangles")->capture_default_str();
  cmd->add_option("--order", o->order, "continuum law: 2 | 3 | 4 | full")->capture_default_str();
  cmd->add_option("--frames", o->frames, "largest number of HDF5/XDMF frames")
      ->capture_default_str();
  cmd->add_option("--max-halvings", o->max_halvings, "halvings of a failing step's dt")
      ->capture_default_str();
  cmd->add_option("--step-iterations", o->step_iterations,
                  "solver iterations per step: L-BFGS per multiplier update (discrete), Newton "
                  "(continuum); 0 = defaults 20000 and 50")
      ->capture_default_str();
  cmd->add_option("--out", o->out,
                  "write dynamics.{csv,json,h5,xdmf,png} (must be empty unless --force-overwrite)")
      ->check(nonempty_path());
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("!--no-picture", o->picture,
                "with --out: no cells.png (the first and the last frame, drawn as rbc render "
                "draws them)");
  cmd->add_flag("--json", o->json, "print the JSON summary on stdout");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  cmd->callback([o, &action] { action = [o]() -> int { return run(*o); }; });
}

}  // namespace rbc::app
