// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc dynamics`: overdamped dynamics of either model (MODEL.md section 6) by backward Euler
// minimising movements: shape recovery after release (Hochmuth, Worthy & Evans 1979), the
// time course of a stretch (paper Fig. 6), and the Helfrich relaxation (paper Fig. 5,
// continuum only). The scenes are the library's (compare/dynamics_scene.hpp); this command
// reads the options and writes the time series as CSV/JSON, the shapes as one HDF5 + XDMF time
// series, and a PNG of the diameters against time.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/interrupt.hpp"
#include "app/model_options.hpp"
#include "app/render.hpp"
#include "app/run_config.hpp"
#include "compare/dynamics_scene.hpp"
#include "compare/experiment.hpp"
#include "compare/plot.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"

namespace rbc::app {

namespace {

struct DynamicsCli {
  std::string model = "continuum";
  std::string scene = "release";
  std::string scheme = "be";  ///< be (backward Euler) | bdf2 (discrete only)
  std::string order = "2";
  DynamicsSceneOptions scene_options;  ///< the numbers; model, scene, scheme, order from above
  ModelCli physics;                    ///< the model option group (app/model_options.hpp)
  int frames = 100;
  std::string out;
  bool json = false, quiet = false, verbose = false, overwrite = false;
  bool picture = true;  ///< --out: cells.png of the first and the last frame (--no-picture)
  /// What produced the run: command, resolved configuration, provenance (app/run_config.hpp);
  /// --json, dynamics.json and run.json include it, dynamics.csv and dynamics.h5 carry it.
  nlohmann::json record;
};

/// The library's quantities -> this command's options (rbc: error: --dt 0: time step dt ...).
const OptionNames kSceneOptionNames = {
    {"model", "--model"},
    {"scene", "--scene"},
    {"time scheme", "--scheme"},
    {"time step dt", "--dt"},
    {"duration", "--duration"},
    {"membrane viscosity", "--membrane-viscosity"},
    {"dilatational ratio eta_d/eta_m", "--dilatational-ratio"},
    {"force (discrete model)", "--force"},
    {"force (continuum model)", "--force"},
    {"step tolerance", "--tolerance"},
    {"regulariser (fraction of the p=2 law)", "--regulariser"},
    {"normal drag", "--normal-drag"},
    {"vertices", "--vertices"},
    {"elements", "--elements"},
    {"max halvings", "--max-halvings"},
    {"step iterations", "--step-iterations"},
};

/// The scene's and the model option group's quantities -> this command's options.
OptionNames dynamics_option_names() {
  OptionNames names = model_option_names();
  names.insert(kSceneOptionNames.begin(), kSceneOptionNames.end());
  return names;
}

/// The library's options from the command line (names parsed, everything validated).
DynamicsSceneOptions scene_options(const DynamicsCli& o) {
  DynamicsSceneOptions so = o.scene_options;
  so.model = dynamics_model_from_string(o.model);
  so.scene = dynamics_scene_from_string(o.scene);
  so.scheme = time_scheme_from_string(o.scheme);
  try {
    so.order = wlc_expansion_from_string(o.order);
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument("--order " + o.order + ": expected one of 2, 3, 4, full");
  }
  so.network = to_network_parameters(o.physics);  // WLC, steric, bending, bead contact
  so.validate();
  if (o.frames < 1)
    throw std::invalid_argument("--frames " + std::to_string(o.frames) +
                                ": the number of frames must be >= 1");
  return so;
}

/// One HDF5 file with every frame and an XDMF temporal collection over it.
/// The run record's attributes (record_attributes) are on the file.
void write_time_series(const std::string& dir, const DynamicsSceneResult& r, int frame_every,
                       const nlohmann::json& record) {
  const TrajectoryResult& traj = r.trajectory;
  const std::string h5_path = dir + "/dynamics.h5";
  TempFile tmp(h5_path);  // removed on every path that does not commit it
  std::vector<size_t> frames;
  for (size_t k = 0; k < traj.snapshots.size(); ++k)
    if (k % frame_every == 0 || k + 1 == traj.snapshots.size()) frames.push_back(k);
  const auto nf = static_cast<hsize_t>(r.faces.cols());
  const auto nv = static_cast<hsize_t>(traj.snapshots.front().cols());
  {
    H5File f = H5File::create(tmp.path(), h5_path);
    f.write("/mesh/faces", r.faces.data(), nf, 3);
    std::vector<double> times;
    for (size_t k : frames) {
      std::ostringstream name;
      name << "/frames/" << std::setw(6) << std::setfill('0') << k << "/positions_um";
      f.write(name.str(), traj.snapshots[k].data(), nv, 3);
      times.push_back(traj.samples[k].t_s);
    }
    f.write("/time_s", times.data(), times.size(), 1);
    for (const auto& [name, value] : record_attributes(record)) f.write_attribute(name, value);
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
      << "    <Time Value=\"" << std::setprecision(10) << traj.samples[k].t_s << "\"/>\n"
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

/// dynamics.csv, .h5/.xdmf, cells.png (unless --no-picture; recorded in j), dynamics.json, the
/// diameter plot and, last, run.json: the JSON summary with the run record, "complete" and
/// "status", which `rbc dynamics --config DIR/run.json` reads back to repeat the run.
void write_outputs(const DynamicsCli& o, const DynamicsSceneOptions& so,
                   const DynamicsSceneResult& r, nlohmann::json& j, const ProgressSink& progress) {
  const TrajectoryResult& traj = r.trajectory;
  CsvTable csv;
  csv.comments = {"rbc dynamics --model " + o.model + " --scene " + o.scene,
                  "units: time s, diameters um, energy pN*um; lambda = D_A/D_T"};
  for (const std::string& line : record_comment_lines(o.record)) csv.comments.push_back(line);
  csv.header = {"t_s",         "axial_um",   "transverse_um", "lambda",
                "energy_pNum", "area_drift", "volume_drift",  "iterations"};
  for (const auto& s : traj.samples)
    csv.rows.push_back({s.t_s, s.axial_um, s.transverse_um, s.axial_um / s.transverse_um,
                        s.energy_pNum, s.area_drift, s.volume_drift,
                        static_cast<double>(s.iterations)});
  write_csv(o.out + "/dynamics.csv", csv);
  write_time_series(o.out, r, std::max(1, static_cast<int>(traj.snapshots.size()) / o.frames),
                    o.record);
  if (o.picture) {
    // cells.png: the first and the last frame (app/render.hpp); never fails the run.
    RenderRequest cells{{o.out + "/dynamics.xdmf"},
                        o.out + "/cells.png",
                        "",
                        "rbc dynamics: " + o.model + ", " + o.scene,
                        record_png_text(o.record)};
    const std::string why_not = draw_cells(cells);
    j[why_not.empty() ? "picture" : "picture_not_drawn"] = why_not.empty() ? "cells.png" : why_not;
    if (!why_not.empty()) report(progress, "no cells.png: " + why_not);
  }
  write_text_atomic(o.out + "/dynamics.json", j.dump(2) + "\n");
  PlotSpec p;
  p.title = "rbc dynamics: " + o.model + ", " + o.scene;
  p.xlabel = "time (s)";
  p.ylabel = "diameter (µm)";
  p.series.push_back({"D_{A}", "dynamics.csv", "1:2", "lines", "#1f77b4"});
  p.series.push_back({"D_{T}", "dynamics.csv", "1:3", "lines", "#d62728"});
  if (so.scene == DynamicsScene::release) {
    // Fitted exponential for lambda, drawn on the right axis.
    const RecoveryFit& fit = r.recovery;
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
  // Last: run.json is the commit record of the set (and reads back with --config).
  nlohmann::json run = j;
  run["complete"] = true;
  run["status"] = "finished";
  run["files"] = {"dynamics.csv", "dynamics.json", "dynamics.h5", "dynamics.xdmf"};
  write_text_atomic(o.out + "/run.json", run.dump(2) + "\n");
}

int run(const DynamicsCli& o) {
  DynamicsSceneOptions so = scene_options(o);
  so.cancel = interrupt_check();
  if (!o.out.empty()) prepare_output_directory(o.out, o.overwrite);
  const ProgressSink progress = stderr_progress(o.quiet, o.verbose);
  const DynamicsSceneResult r = run_dynamics_scene(so, progress);
  if (!r.static_converged) {
    std::cerr << "rbc: error: the static equilibrium did not converge (" << r.static_status
              << "): largest vertex force residual " << std::scientific << r.static_residual_pN
              << " pN\n";
    return 1;
  }
  if (!r.trajectory.converged) {  // nothing written: a trajectory that stops early is no result
    std::cerr << "rbc: error: " << r.trajectory.status << "\n";
    return 1;
  }
  nlohmann::json j = o.record;  // command, resolved configuration, provenance
  j.update(dynamics_summary_json(so, r));
  if (!o.out.empty()) write_outputs(o, so, r, j, progress);
  if (o.json) {
    std::cout << j.dump(2) << "\n";
  } else {
    const TrajectoryResult& traj = r.trajectory;
    std::cout << "# rbc dynamics: " << o.model << ", scene " << o.scene << ", eta_m "
              << so.membrane_viscosity_pN_s_per_um << " pN s/um, dt " << so.dt_s << " s, "
              << traj.samples.size() << " samples, wall " << std::setprecision(3) << traj.wall_s
              << " s\n";
    for (const char* k :
         {"recovery_time_s", "recovery_time_err_s", "geometry_factor", "kelvin_voigt_time_s",
          "hochmuth_recovery_time_s", "eta_matching_hochmuth_pN_s_per_um",
          "final_axial_relative_to_static", "disc_diameter_before_um", "disc_diameter_after_um"})
      if (j.contains(k))
        std::cout << k << " = " << std::setprecision(6) << j[k].get<double>() << "\n";
    const auto& last = traj.samples.back();
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
  cmd->add_option("--force", o->scene_options.force_pN, "total bead force F (pN)")
      ->capture_default_str();
  cmd->add_option("--membrane-viscosity", o->scene_options.membrane_viscosity_pN_s_per_um,
                  "membrane shear viscosity eta_m (pN s/um = Pa s um)")
      ->capture_default_str();
  cmd->add_option("--dilatational-ratio", o->scene_options.dilatational_ratio,
                  "continuum: eta_d / eta_m (the network's value is 2)")
      ->capture_default_str();
  cmd->add_option("--duration", o->scene_options.duration_s, "simulated time T (s)")
      ->capture_default_str();
  cmd->add_option("--dt", o->scene_options.dt_s, "time step (s)")->capture_default_str();
  cmd->add_option("--tolerance", o->scene_options.tolerance_pN_per_s,
                  "step force tolerance per unit dt (pN/s): tolerance = this x dt; 0 = 1 "
                  "(release, stretch) or 1e-5 (relax)")
      ->capture_default_str();
  cmd->add_option("--regulariser", o->scene_options.regulariser,
                  "relax: in-plane mesh regulariser, fraction of the p=2 law, in (0, 1]")
      ->capture_default_str();
  cmd->add_option("--normal-drag", o->scene_options.normal_drag_pN_s_per_um3,
                  "relax: normal drag of the fluids per area (pN s/um^3, qualitative)")
      ->capture_default_str();
  cmd->add_option("--vertices,-n", o->scene_options.vertices, "discrete: network vertices")
      ->capture_default_str();
  cmd->add_option("--elements", o->scene_options.elements, "continuum: triangles")
      ->capture_default_str();
  cmd->add_option("--order", o->order, "continuum law: 2 | 3 | 4 | full")->capture_default_str();
  add_model_options(cmd, o->physics);
  cmd->add_option("--frames", o->frames, "largest number of HDF5/XDMF frames")
      ->capture_default_str();
  cmd->add_option("--max-halvings", o->scene_options.max_halvings,
                  "halvings of a failing step's dt")
      ->capture_default_str();
  cmd->add_option("--step-iterations", o->scene_options.step_iterations,
                  "solver iterations per step: L-BFGS per multiplier update (discrete), Newton "
                  "(continuum); 0 = defaults 20000 and 50")
      ->capture_default_str();
  cmd->add_option("--out", o->out,
                  "write dynamics.{csv,json,h5,xdmf,png} and run.json (must be empty unless "
                  "--force-overwrite)")
      ->check(nonempty_path());
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("!--no-picture", o->picture,
                "with --out: no cells.png (the first and the last frame, drawn as rbc render "
                "draws them)");
  cmd->add_flag("--json", o->json, "print the JSON summary on stdout");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  add_verbose_flag(cmd, o->verbose);
  cmd->callback([o, cmd, &action] {
    make_cancellable();  // polls interrupt_check() between steps: see app/interrupt.hpp
    action = [o, cmd]() -> int {
      o->record = run_record(*cmd);
      return naming_options(dynamics_option_names(), [&] { return run(*o); });
    };
  });
}

}  // namespace rbc::app
