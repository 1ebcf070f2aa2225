// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc stretch`: the optical-tweezers stretch (Mills et al. 2004) of one model over a list
// of forces, by continuation: each force starts from the previous equilibrium.
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/interrupt.hpp"
#include "app/model_options.hpp"
#include "app/render.hpp"
#include "app/run_config.hpp"
#include "app/warm_start.hpp"
#include "compare/accuracy_choice.hpp"
#include "continuum/adapted_mesh.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/error_indicator.hpp"
#include "continuum/loop_stretch.hpp"
#include "continuum/refined_mesh.hpp"
#include "core/geometry.hpp"
#include "core/io.hpp"
#include "core/rest_shape.hpp"
#include "core/validation.hpp"
#include "discrete/stretch.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc::app {

nlohmann::json mesh_report_json(const MeshQualityReport& r);  // cmd_mesh.cpp

namespace {

/// Which model `rbc stretch` runs (--model discrete | continuum).
enum class StretchModel { discrete, continuum };

/// Which continuum mesh (--mesh): the Phi-minimised icosphere, the CGAL mesh graded to the
/// scene (continuum/adapted_mesh.hpp), or the icosphere refined by red-green refinement towards
/// the same scene, keeping its mirrors (continuum/refined_mesh.hpp).
enum class ContinuumMesh { uniform, adapted, refined };
/// Which continuum element (--element): linear triangles with Juelicher bending, or the C1 Loop
/// subdivision element with every term on its smooth limit surface (continuum/loop_stretch.hpp).
enum class ContinuumElement { linear, loop };
/// --mesh-volume: the refined mesh with its vertices on the Evans-Fung surface, or scaled to
/// enclose its volume (RefinedMeshOptions::match_volume).
enum class MeshVolume { surface, scale };

/// Options in natural units (nm, J, pN), converted once in to_network_parameters().
struct StretchCli {
  StretchModel model = StretchModel::discrete;
  std::string forces = "0,16,19.5,30.6,38,46.6,67.6,87.6,108.8,130,151,172.8,193";
  int vertices = 2000;
  RestMeshQuality mesh_quality = RestMeshQuality::phi_minimised;
  /// --mesh-orientation: where the icosahedron lies (mirror-planes: the scene's full mirror
  /// group, with the bead patches cut between x levels).
  TriangulationOrientation orientation = TriangulationOrientation::dimple_vertex;
  ModelCli physics;              ///< the model option group (app/model_options.hpp)
  double tolerance_pN = 1e-3;    ///< discrete default; the continuum's is Newton's 1e-6 pN
  bool tolerance_given = false;  ///< --tolerance on the command line (the continuum honours it)
  int max_iterations = 50000;
  WlcExpansion order = WlcExpansion::order2;
  int elements = 4000;
  ContinuumElement element = ContinuumElement::linear;
  ContinuumMesh mesh = ContinuumMesh::uniform;
  /// --mesh-size-ratio (--mesh adapted or refined): coarse / fine edge length
  double mesh_size_ratio = AdaptedMeshOptions{}.size_ratio;
  /// --mesh-seed (--mesh adapted): turns the mesher's initial points (another triangulation)
  unsigned mesh_seed = 0;
  /// --mesh-volume (--mesh refined)
  MeshVolume mesh_volume = MeshVolume::surface;
  /// --symmetry mirror: solve on the mirror-symmetric configurations (core/mirror_symmetry.hpp)
  Symmetry symmetry = Symmetry::none;
  /// --symmetry-check (continuum, with --symmetry mirror): which equilibria are checked
  SymmetryCheckAt symmetry_check_at = SymmetryCheckAt::every_force;
  /// --contact-load, --measure (continuum): how the bead force is applied and D_A, D_T measured
  ContinuumLoad contact_load = ContinuumLoad::vertex_patch;
  ContinuumMeasure measure = ContinuumMeasure::vertices;
  std::string out;
  std::string warm_start;  ///< --warm-start DIR: a previous --out to re-solve from
  bool json = false, quiet = false, verbose = false, overwrite = false;
  bool picture = true;  ///< --out: cells.png of the first and the largest force (--no-picture)
  /// --accuracy P%: choose model and resolution from the trade-off table (compare/
  /// accuracy_choice.hpp); the choice is stated on stderr and in every JSON point.
  std::string accuracy;
  nlohmann::json accuracy_choice;  ///< null unless --accuracy chose
  /// What produced the run: command, resolved configuration, provenance (app/run_config.hpp);
  /// run.json starts from it, stretch.csv and the shape files carry it, --json includes it.
  nlohmann::json record;
};

/// Library quantities -> this command's options (errors name the option the user typed).
OptionNames stretch_option_names() {
  OptionNames names = model_option_names();
  names.insert({{"force (discrete model)", "--force"},
                {"force (continuum model)", "--force"},
                {"force tolerance", "--tolerance"},
                {"max iterations", "--max-iterations"},
                {"mesh size ratio", "--mesh-size-ratio"}});
  return names;
}

NetworkParameters to_network_parameters(const StretchCli& o) {
  NetworkParameters p = to_network_parameters(o.physics);
  p.tweezers.keep_equal_x_together = o.orientation == TriangulationOrientation::mirror_planes;
  return p;
}

/// Stretch options from the command line, validated (tolerance, iteration budget).
StretchOptions to_stretch_options(const StretchCli& o) {
  StretchOptions so;
  so.minimiser.force_tolerance = o.tolerance_pN;
  so.minimiser.max_iterations = o.max_iterations;
  so.symmetry = o.symmetry;
  so.validate();
  return so;
}

/// Checks --out last, once every other input is known good: no two forces may write the same
/// shape file, and the directory must be writable and empty (unless --force-overwrite).
/// Returns true when the check created the directory (so a later refusal can remove it).
bool prepare_stretch_output(const StretchCli& o, const std::vector<double>& forces) {
  if (o.out.empty()) return false;
  require_distinct(forces, "--force", o.forces);
  std::error_code ec;
  const bool existed = std::filesystem::exists(o.out, ec);
  prepare_output_directory(o.out, o.overwrite);
  return !existed;
}

/// Reads --warm-start DIR (if given) against the mesh just built. A refusal (wrong model, mesh
/// or forces; missing or corrupt file) happens before anything is written: the --out directory
/// the up-front check created is removed again, so a refused run leaves nothing behind.
StretchState read_checked_warm_start(const StretchCli& o, bool created_out, const char* model,
                                     Eigen::Index vertices, const Faces& faces,
                                     const std::vector<double>& forces) {
  if (o.warm_start.empty()) return {};
  try {
    return read_warm_start(o.warm_start, model, to_string(o.orientation), vertices, faces, forces);
  } catch (...) {
    if (created_out) discard_empty_output_directory(o.out);
    throw;
  }
}

/// Shape file tag: one decimal (shape_16.0pN) or as many as tell two forces apart.
std::string force_tag(double f) {
  return number_tag(f, 1);
}

/// One equilibrium as both models report it (elements = 0 for the discrete network).
struct StretchRow {
  double force_pN = 0, axial_um = 0, transverse_um = 0, energy_pNum = 0;
  int iterations = 0;
  bool converged = false;
  double wall_s = 0;
  int vertices = 0, elements = 0;
  double residual_pN = 0, area_drift = 0, volume_drift = 0;
  std::string status;
  bool warm = false;             ///< solved from its --warm-start equilibrium
  int symmetry_order = 1;        ///< --symmetry mirror: order of the group of the last solve
  bool symmetry_broken = false;  ///< --symmetry mirror: the equilibrium is not symmetric
};

template <class Point>
StretchRow to_row(const Point& p, int elements) {
  return {p.force_pN,       p.axial_um,     p.transverse_um,     p.energy_pNum, p.iterations,
          p.converged,      p.wall_s,       p.vertices,          elements,      p.residual_pN,
          p.area_drift,     p.volume_drift, to_string(p.status), p.warm,        p.symmetry_order,
          p.symmetry_broken};
}

/// DIR/run.json, the manifest of `stretch --out`: rewritten (atomically) when the run starts,
/// after every force whose shape files are in place, when the run is interrupted and at the end,
/// so at any moment it says which results are complete. Fields: "complete" (true only when every
/// requested force was solved and stretch.csv written), "status" (running | interrupted |
/// failed | finished), "reason" (why it is incomplete), "forces_requested_pN", "forces_complete"
/// (force and shape files of each solved force), the run record ("command", "config": the
/// resolved options, which `--config run.json` reads back; "provenance": version, command line,
/// date, host, threads, BLAS kernel; app/run_config.hpp), and at the end "points" as in --json.
class StretchManifest {
 public:
  StretchManifest(std::string dir, const nlohmann::json& record, const nlohmann::json& run,
                  const std::vector<double>& forces)
      : dir_(std::move(dir)), run_(record) {
    run_.update(run);
    run_["forces_requested_pN"] = forces;
    run_["forces_complete"] = nlohmann::json::array();
  }
  void running() { write(false, "running", "the run has not finished"); }
  void force_done(double force_pN, const std::string& shape_base) {
    const std::string name = std::filesystem::path(shape_base).filename().string();
    run_["forces_complete"].push_back(
        {{"force_pN", force_pN}, {"shape_h5", name + ".h5"}, {"shape_xdmf", name + ".xdmf"}});
    running();
  }
  /// Records the interruption; if even that write fails, removes run.json (never throws).
  void interrupted(const std::string& signal) noexcept {
    if (dir_.empty()) return;
    record_failed_manifest(dir_ + "/run.json", [&] {
      const std::size_t done = run_["forces_complete"].size(),
                        all = run_["forces_requested_pN"].size();
      write(false, "interrupted",
            "interrupted by " + signal + " after " + std::to_string(done) + " of " +
                std::to_string(all) + " forces; stretch.csv not written");
    });
  }
  /// Records the failure with the error line's text; if even that write fails (a full disk),
  /// removes run.json, so no manifest says "running" after the process ended (never throws).
  void failed(const std::string& what) noexcept {
    if (dir_.empty()) return;
    record_failed_manifest(dir_ + "/run.json", [&] { write(false, "failed", what); });
  }
  /// The picture beside the shapes: its file name, or why there is none.
  void picture(const std::string& file, const std::string& why_not) {
    if (why_not.empty())
      run_["picture"] = file;
    else
      run_["picture_not_drawn"] = why_not;
  }
  void finished(const nlohmann::json& points) {
    run_["points"] = points;
    run_.erase("reason");
    run_["stretch_csv"] = "stretch.csv";
    write(true, "finished", "");
  }
  bool active() const { return !dir_.empty(); }

 private:
  void write(bool complete, const std::string& status, const std::string& reason) {
    if (dir_.empty()) return;
    run_["complete"] = complete;
    run_["status"] = status;
    if (!reason.empty()) run_["reason"] = reason;
    write_text_atomic(dir_ + "/run.json", run_.dump(2) + "\n");
  }
  std::string dir_;
  nlohmann::json run_;
};

/// OUT/shape_<F>pN.h5/.xdmf: the equilibrium at one force (positions, displacement from rest,
/// the element fields given, the force and the multipliers that --warm-start reads back, the
/// run record as text attributes), then
/// the manifest records the force as complete.
void write_force_shape(const StretchCli& o, StretchManifest& manifest, double force_pN,
                       const Positions& x, const Positions& rest, const Faces& faces,
                       const ConstraintMultipliers& multipliers,
                       std::vector<MeshField> face_fields) {
  const Eigen::VectorXd u = (x - rest).colwise().norm().transpose();
  MeshSnapshot s{x,
                 faces,
                 {{"displacement_um", u}},
                 std::move(face_fields),
                 {{"force_pN", force_pN},
                  {kLambdaAreaAttribute, multipliers.area_pN_per_um},
                  {kLambdaVolumeAttribute, multipliers.volume_pN_per_um2}},
                 record_attributes(o.record)};
  const std::string base = o.out + "/shape_" + force_tag(force_pN) + "pN";
  write_mesh_snapshot(base, s);
  manifest.force_done(force_pN, base);
}

/// Runs `solve` (the solve, the shape files as forces are done and the final outputs) with the
/// manifest saying "running"; on Cancelled the manifest records the interruption, on any other
/// exception the failure and its reason, before the exception goes on to main() (exit
/// 130/143, or 2).
template <class Solve>
auto with_manifest(StretchManifest& manifest, Solve&& solve) {
  try {
    manifest.running();
    return solve();
  } catch (const Cancelled&) {
    manifest.interrupted(interrupt_name());
    throw;
  } catch (const std::exception& e) {
    manifest.failed(e.what());
    throw;
  }
}

/// OUT/cells.png: the shapes at the first and the largest force (app/render.hpp). A picture
/// that cannot be drawn (no matplotlib) is noted on stderr and in run.json, never an error.
void draw_stretch_picture(const StretchCli& o, const std::vector<StretchRow>& pts,
                          StretchManifest& manifest) {
  RenderRequest r;
  double largest = pts.front().force_pN;
  for (const auto& p : pts) largest = std::max(largest, p.force_pN);
  for (double f : {pts.front().force_pN, largest}) {
    const std::string file = o.out + "/shape_" + force_tag(f) + "pN.xdmf";
    if (std::filesystem::exists(file) && (r.files.empty() || r.files.back() != file))
      r.files.push_back(file);
  }
  if (r.files.empty()) return;
  const bool continuum = o.model == StretchModel::continuum;
  r.title = continuum ? "continuum model, " + std::to_string(pts.front().elements) + " elements"
                      : "spectrin network, " + std::to_string(pts.front().vertices) + " vertices";
  r.out_png = o.out + "/cells.png";
  r.metadata = record_png_text(o.record);
  const std::string why_not = draw_cells(r);
  manifest.picture("cells.png", why_not);
  if (!why_not.empty() && !o.quiet) std::cerr << "rbc: note: no cells.png: " << why_not << "\n";
}

/// Prints the table (or JSON), writes stretch.csv and run.json under --out, and reports
/// every non-converged force with its residual. Returns the exit code (1 if any failed).
int emit_stretch(const StretchCli& o, const std::vector<StretchRow>& pts,
                 const std::vector<std::string>& comments, StretchManifest& manifest) {
  const bool continuum = o.model == StretchModel::continuum;
  nlohmann::json rows = nlohmann::json::array();
  CsvTable csv;
  csv.comments = comments;
  for (const std::string& line : record_comment_lines(o.record)) csv.comments.push_back(line);
  if (!o.accuracy_choice.is_null())
    csv.comments.push_back(o.accuracy_choice["reason"].get<std::string>());
  csv.header = {"force_pN",   "axial_um",  "transverse_um", "energy_pNum",
                "iterations", "converged", "wall_s",        "vertices"};
  if (continuum) csv.header.push_back("elements");
  for (const char* h : {"residual_pN", "area_drift", "volume_drift"}) csv.header.push_back(h);
  for (const auto& p : pts) {
    nlohmann::json j = {{"force_pN", p.force_pN},
                        {"axial_um", p.axial_um},
                        {"transverse_um", p.transverse_um},
                        {"energy_pNum", p.energy_pNum},
                        {"iterations", p.iterations},
                        {"converged", p.converged},
                        {"wall_s", p.wall_s},
                        {"vertices", p.vertices},
                        {"residual_pN", p.residual_pN},
                        {"area_drift", p.area_drift},
                        {"volume_drift", p.volume_drift}};
    std::vector<double> r = {p.force_pN,
                             p.axial_um,
                             p.transverse_um,
                             p.energy_pNum,
                             static_cast<double>(p.iterations),
                             p.converged ? 1.0 : 0.0,
                             p.wall_s,
                             static_cast<double>(p.vertices)};
    if (!o.warm_start.empty()) j["warm_started"] = p.warm;
    if (o.symmetry == Symmetry::mirror) {
      j["symmetry_order"] = p.symmetry_order;
      j["symmetry_broken"] = p.symmetry_broken;
    }
    if (!o.accuracy_choice.is_null()) j["accuracy_choice"] = o.accuracy_choice;
    if (continuum) {
      j["elements"] = p.elements;
      r.push_back(p.elements);
    }
    for (double v : {p.residual_pN, p.area_drift, p.volume_drift}) r.push_back(v);
    rows.push_back(j);
    csv.rows.push_back(r);
  }
  if (!o.out.empty()) {
    write_csv(o.out + "/stretch.csv", csv);
    if (o.picture && !pts.empty()) draw_stretch_picture(o, pts, manifest);
    manifest.finished(rows);  // last: the manifest is the commit record of the set
  }
  if (o.json) {
    nlohmann::json out = o.record;
    out["points"] = rows;
    std::cout << out.dump(2) << "\n";
  } else {
    std::cout << "# " << comments.back() << "\n";
    std::cout << std::setw(9) << "force_pN" << std::setw(11) << "axial_um" << std::setw(14)
              << "transverse_um" << std::setw(14) << "energy_pNum" << std::setw(11) << "iterations"
              << std::setw(10) << "converged" << std::setw(9) << "wall_s" << std::setw(10)
              << (continuum ? "elements" : "vertices") << "\n";
    for (const auto& p : pts)
      std::cout << std::fixed << std::setprecision(2) << std::setw(9) << p.force_pN
                << std::setprecision(4) << std::setw(11) << p.axial_um << std::setw(14)
                << p.transverse_um << std::setprecision(3) << std::setw(14) << p.energy_pNum
                << std::setw(11) << p.iterations << std::setw(10) << (p.converged ? "yes" : "NO")
                << std::setprecision(2) << std::setw(9) << p.wall_s << std::setw(10)
                << (continuum ? p.elements : p.vertices) << "\n";
  }
  int status = 0;
  for (const auto& p : pts)
    if (!p.converged) {
      // Formatted on their own (scientific), whatever the table left in std::cout's state.
      std::cerr << "rbc: error: force " + format_number(p.force_pN) + " pN did not converge (" +
                       p.status + "): largest vertex force residual " +
                       format_scientific(p.residual_pN) + " pN, area drift " +
                       format_scientific(p.area_drift) + ", volume drift " +
                       format_scientific(p.volume_drift) + "\n";
      status = 1;
    }
  return status;
}

int run_discrete(const StretchCli& o) {
  const std::vector<double> forces = parse_force_list(o.forces);
  for (double f : forces) validate_discrete_force(f);
  const NetworkParameters params = to_network_parameters(o);
  StretchOptions so = to_stretch_options(o);
  const bool created_out = prepare_stretch_output(o, forces);
  const ProgressSink progress = stderr_progress(o.quiet, o.verbose);
  RestShapeOptions ro;
  ro.target_vertices = o.vertices;
  ro.quality = o.mesh_quality;
  ro.orientation = o.orientation;
  MeshQualityReport mesh_report;
  report(progress, "building the rest network (N ~ " + std::to_string(o.vertices) + ")");
  const TriMesh mesh = make_rest_shape(ro, &mesh_report);
  const Network net = build_network(mesh, params);
  const double rest_force = largest_rest_inplane_force_pN(net);
  {
    std::ostringstream m;
    m << "network: " << mesh_report.vertices << " vertices, Phi/A0 = " << mesh_report.phi_over_area
      << ", largest rest in-plane force = " << rest_force << " pN, contact patches "
      << net.patch.area_plus_um2 << " / " << net.patch.area_minus_um2 << " um^2";
    report(progress, m.str());
  }
  so.minimiser.cancel = interrupt_check();
  const StretchState warm =
      read_checked_warm_start(o, created_out, "discrete", net.rest.cols(), net.topo.faces, forces);
  StretchManifest manifest(o.out, o.record,
                           {{"model", "discrete"},
                            {"mesh", mesh_report_json(mesh_report)},
                            {"mesh_orientation", to_string(o.orientation)},
                            {"largest_rest_inplane_force_pN", rest_force}},
                           forces);
  // Each shape is written (and the manifest updated) as soon as its force is solved.
  so.on_point = [&](const StretchPoint& p) {
    if (o.out.empty()) return;
    write_force_shape(o, manifest, p.force_pN, p.x, net.rest, net.topo.faces, p.multipliers, {});
  };
  if (!warm.empty()) report(progress, "warm start from " + o.warm_start);
  return with_manifest(manifest, [&] {
    const std::vector<StretchPoint> pts = run_stretch(net, forces, so, progress, warm);
    std::vector<StretchRow> rows;
    for (const auto& p : pts) rows.push_back(to_row(p, 0));
    return emit_stretch(
        o, rows,
        {"rbc stretch --model discrete: optical-tweezers stretch of the spectrin network",
         "units: force pN, diameters um, energy pN*um, wall time s",
         "vertices " + std::to_string(mesh_report.vertices) + ", Phi/A0 " +
             std::to_string(mesh_report.phi_over_area) + ", largest rest in-plane force " +
             std::to_string(rest_force) + " pN"},
        manifest);
  });
}

// Continuum branch on the Loop element: the uniform icosphere with its vertices on the Evans-Fung
// surface as the control mesh, the load on the caps of the rest limit surface, the diameters
// measured on the limit surface (continuum/loop_stretch.hpp). The shape files hold the limit
// surface at the mesh's vertices.
int run_loop_continuum(const StretchCli& o) {
  const std::vector<double> forces = parse_force_list(o.forces);
  for (double f : forces) validate_continuum_force(f);
  const NetworkParameters params = to_network_parameters(o);  // WLC, steric, bending, tweezers
  to_stretch_options(o);  // the same --tolerance and --max-iterations checks as the network's
  LoopStretchOptions lo;
  lo.newton.max_iterations = std::min(o.max_iterations, lo.newton.max_iterations);
  if (o.tolerance_given) lo.newton.force_tolerance = o.tolerance_pN;
  lo.symmetry = o.symmetry;
  lo.newton.validate();
  const bool created_out = prepare_stretch_output(o, forces);
  const ProgressSink progress = stderr_progress(o.quiet, o.verbose);
  MeshQualityReport mesh_report;
  const EvansFungShape shape;
  TriMesh mesh = make_continuum_mesh(o.elements, 0, o.orientation, &mesh_report);
  for (int i = 0; i < mesh.x.cols(); ++i) mesh.x.col(i) = evans_fung_project(shape, mesh.x.col(i));
  // A model refused (its caps empty, say) leaves no --out directory this run created.
  const LoopContinuumModel model = [&] {
    try {
      return build_loop_continuum_model(
          mesh, make_membrane_law(params.wlc, params.steric, o.order), params.bending,
          rest_contact_plane(shape, params.tweezers.contact_fraction));
    } catch (...) {
      if (created_out) discard_empty_output_directory(o.out);
      throw;
    }
  }();
  report(progress, "Loop element: " + std::to_string(model.topo.num_vertices) +
                       " control points, " + std::to_string(model.topo.num_faces()) +
                       " triangles, " + std::to_string(model.quadrature.size()) +
                       " quadrature points, law " + model.law.name);
  lo.newton.cancel = interrupt_check();
  StretchManifest manifest(o.out, o.record,
                           {{"model", "continuum"},
                            {"element", "loop"},
                            {"order", to_string(o.order)},
                            {"mesh", mesh_report_json(mesh_report)},
                            {"mesh_kind", "uniform"},
                            {"mesh_orientation", to_string(o.orientation)},
                            {"symmetry", to_string(o.symmetry)},
                            {"contact_load", "limit-surface-caps"},
                            {"measure", "limit-surface"}},
                           forces);
  return with_manifest(manifest, [&] {
    const std::vector<LoopStretchPoint> pts = run_loop_stretch(model, forces, lo, progress);
    if (!o.out.empty()) {
      const Eigen::SparseMatrix<double> at_vertices = loop_limit_sampling_matrix(model.topo, 0);
      const Positions rest = (at_vertices * model.rest.transpose()).transpose();
      for (const LoopStretchPoint& p : pts)
        write_force_shape(o, manifest, p.force_pN, (at_vertices * p.x.transpose()).transpose(),
                          rest, model.topo.faces, p.multipliers, {});
    }
    std::vector<StretchRow> rows;
    for (const LoopStretchPoint& p : pts) {
      StretchRow r;
      r.force_pN = p.force_pN;
      r.axial_um = p.diameters.axial_um;
      r.transverse_um = p.diameters.transverse_um;
      r.energy_pNum = p.energy_pNum;
      r.iterations = p.iterations;
      r.converged = p.status == NewtonStatus::converged;
      r.wall_s = p.wall_s;
      r.vertices = model.topo.num_vertices;
      r.elements = model.topo.num_faces();
      r.residual_pN = p.residual_pN;
      r.area_drift = p.area_drift;
      r.volume_drift = p.volume_drift;
      r.status = to_string(p.status);
      r.symmetry_order = p.symmetry_order;
      r.symmetry_broken = p.symmetry_broken;
      rows.push_back(r);
    }
    return emit_stretch(
        o, rows,
        {"rbc stretch --model continuum --element loop: optical-tweezers stretch, C1 Loop "
         "subdivision element, Newton",
         "units: force pN, diameters um, energy pN*um, wall time s",
         "order " + to_string(o.order) + ", elements " + std::to_string(model.topo.num_faces()) +
             ", control points " + std::to_string(model.topo.num_vertices)},
        manifest);
  });
}

// Continuum branch: surface FEM with the homogenised law of the given order.
int run_continuum(const StretchCli& o) {
  if (o.element == ContinuumElement::loop) return run_loop_continuum(o);
  const std::vector<double> forces = parse_force_list(o.forces);
  for (double f : forces) validate_continuum_force(f);
  const NetworkParameters params = to_network_parameters(o);  // WLC, steric, bending, tweezers
  const WlcExpansion order = o.order;
  to_stretch_options(o);  // the same --tolerance and --max-iterations checks as the network's
  ContinuumOptions co;
  co.newton.max_iterations = std::min(o.max_iterations, 1000);
  co.max_iterations_per_force = std::min(o.max_iterations, co.max_iterations_per_force);
  if (o.tolerance_given) co.newton.force_tolerance_pN = o.tolerance_pN;
  co.newton.symmetry = o.symmetry;
  co.symmetry_check_at = o.symmetry_check_at;
  co.load = o.contact_load;
  co.exact_contact_fraction = params.tweezers.contact_fraction;
  co.measure = o.measure;
  co.validate();
  const bool created_out = prepare_stretch_output(o, forces);
  const ProgressSink progress = stderr_progress(o.quiet, o.verbose);
  MeshQualityReport mesh_report;
  AdaptedMeshOptions ao;
  ao.target_elements = o.elements;
  ao.size_ratio = o.mesh_size_ratio;
  ao.seed = o.mesh_seed;
  ao.contact_fraction = params.tweezers.contact_fraction;
  ao.validate();
  AdaptedMeshReport adapted_report;
  RefinedMeshOptions ro;
  ro.target_elements = o.elements;
  ro.size_ratio = o.mesh_size_ratio;
  ro.contact_fraction = params.tweezers.contact_fraction;
  ro.orientation = o.orientation;
  ro.seed = o.mesh_seed;
  ro.match_volume = o.mesh_volume == MeshVolume::scale;
  ro.validate();
  RefinedMeshReport refined_report;
  const TriMesh mesh = o.mesh == ContinuumMesh::adapted ? make_adapted_mesh(ao, &adapted_report)
                       : o.mesh == ContinuumMesh::refined
                           ? make_refined_mesh(ro, &refined_report)
                           : make_continuum_mesh(o.elements, 0, o.orientation, &mesh_report);
  nlohmann::json mesh_kind = "uniform";
  if (o.mesh == ContinuumMesh::refined) {
    mesh_report = assess_mesh(mesh);
    mesh_report.volume_scale = refined_report.volume_scale;
    const RefinedSizeField& f = refined_report.size;
    mesh_kind = {{"kind", "refined"},
                 {"size_ratio", o.mesh_size_ratio},
                 {"fine_um", f.fine_um},
                 {"cap_plane_um", f.plane_um},
                 {"band_um", f.band_um},
                 {"rim_y_um", f.rim_y_um},
                 {"rim_band_um", f.rim_band_um},
                 {"grading", f.grading},
                 {"coarse_vertices", refined_report.coarse_vertices},
                 {"coarse_elements", refined_report.coarse_elements},
                 {"passes", refined_report.passes},
                 {"volume", o.mesh_volume == MeshVolume::scale ? "scale" : "surface"},
                 {"volume_scale", refined_report.volume_scale},
                 {"seed", o.mesh_seed}};
    report(progress, "refined mesh (red-green refinement of the " +
                         std::to_string(refined_report.coarse_elements) +
                         "-element icosphere): edges down to " + format_number(f.fine_um) +
                         " um beyond |x| = " + format_number(f.plane_um - f.band_um) +
                         " um and around the D_T rim points (0, +-" + format_number(f.rim_y_um) +
                         ", 0) um");
  }
  if (o.mesh == ContinuumMesh::adapted) {
    mesh_report = assess_mesh(mesh);
    mesh_report.volume_scale = adapted_report.volume_scale;
    const SceneSizeField& f = adapted_report.size;
    mesh_kind = {
        {"kind", "adapted"},        {"size_ratio", o.mesh_size_ratio}, {"fine_um", f.fine_um},
        {"coarse_um", f.coarse_um}, {"cap_plane_um", f.plane_um},      {"band_um", f.band_um},
        {"grading", f.grading},     {"passes", adapted_report.passes}, {"seed", o.mesh_seed}};
    report(progress, "adapted mesh (CGAL surface mesher): edges up to " + format_number(f.fine_um) +
                         " um beyond |x| = " + format_number(f.plane_um - f.band_um) +
                         " um, up to " + format_number(f.coarse_um) + " um elsewhere");
  }
  ContinuumParameters cp;
  cp.bending = params.bending;
  cp.tweezers = params.tweezers;
  const ContinuumModel model =
      build_continuum_model(mesh, make_membrane_law(params.wlc, params.steric, order), cp);
  report(progress, "continuum mesh: " + std::to_string(mesh_report.vertices) + " vertices, " +
                       std::to_string(model.num_elements()) + " elements, law " + model.law.name);
  co.newton.cancel = interrupt_check();
  co.lbfgs.cancel = co.newton.cancel;
  const StretchState warm = read_checked_warm_start(o, created_out, "continuum", model.rest.cols(),
                                                    model.topo.faces, forces);
  StretchManifest manifest(o.out, o.record,
                           {{"model", "continuum"},
                            {"order", to_string(order)},
                            {"mesh", mesh_report_json(mesh_report)},
                            {"mesh_kind", mesh_kind},
                            {"mesh_orientation", to_string(o.orientation)},
                            {"symmetry", to_string(o.symmetry)},
                            {"symmetry_check", to_string(o.symmetry_check_at)},
                            {"contact_load", to_string(o.contact_load)},
                            {"measure", to_string(o.measure)}},
                           forces);
  // The continuation (with its secant predictor and bisection) runs in the library, so the
  // shapes are written after the last force; an interrupted run records none as complete.
  if (!warm.empty()) report(progress, "warm start from " + o.warm_start);
  return with_manifest(manifest, [&] {
    const std::vector<ContinuumStretchPoint> pts =
        run_continuum_stretch(model, forces, co, progress, warm);
    if (!o.out.empty())
      for (const auto& p : pts) {
        write_force_shape(o, manifest, p.force_pN, p.x, model.rest, model.topo.faces, p.multipliers,
                          {{"I1", p.fields.i1},
                           {"I2", p.fields.i2},
                           {"tension_max_pN_per_um", p.fields.tension_max_pN_per_um},
                           {"tension_min_pN_per_um", p.fields.tension_min_pN_per_um},
                           {"error_indicator_pN", error_indicator(model, p.x)}});
      }
    std::vector<StretchRow> rows;
    for (const auto& p : pts) rows.push_back(to_row(p, p.elements));
    return emit_stretch(
        o, rows,
        {"rbc stretch --model continuum: optical-tweezers stretch, surface FEM, Newton",
         "units: force pN, diameters um, energy pN*um, wall time s",
         "order " + to_string(order) + ", elements " + std::to_string(model.num_elements()) +
             ", vertices " + std::to_string(mesh_report.vertices)},
        manifest);
  });
}

/// --accuracy P%: sets model, resolution, order and (unless --symmetry was given, which then
/// restricts the choice to its rows) the solver path from the trade-off table, before any
/// work; refusals (std::invalid_argument -> exit 2) name the reason in one line.
/// The table includes the continuum rows on the adapted and the refined meshes
/// (accuracy_by_force_adapted.csv, accuracy_by_force_refined.csv), measured with the exact
/// contact load and the quadric-fit diameters: a choice of one sets --mesh adapted or refined,
/// its --mesh-size-ratio, --contact-load exact-contact and --measure quadric-fit; with
/// --contact-load or --measure given (`load_or_measure_given`) they are left out of the choice.
void choose_stretch_method(StretchCli& o, const std::string& explicit_choice, bool symmetry_given,
                           bool load_or_measure_given) {
  const double percent = parse_accuracy_percent(o.accuracy);
  if (!explicit_choice.empty())
    throw std::invalid_argument("--accuracy " + o.accuracy + " cannot be combined with " +
                                explicit_choice + ": the accuracy table chooses the method");
  const std::vector<double> forces = parse_force_list(o.forces);
  AccuracyTable table;
  try {
    table = load_accuracy_table_with_adapted(default_accuracy_table_path());
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument(std::string("--accuracy: cannot read the trade-off table: ") +
                                e.what());
  }
  if (load_or_measure_given)
    std::erase_if(table.entries, [](const AccuracyEntry& e) {
      return e.method.adapted || e.method.refined || e.method.loop;
    });
  const AccuracyChoice ch = choose_by_accuracy(
      table, forces, percent, symmetry_given ? std::optional<Symmetry>(o.symmetry) : std::nullopt);
  const Method& m = ch.chosen.method;
  o.symmetry = ch.chosen.symmetry;
  o.model = m.kind == MethodKind::discrete ? StretchModel::discrete : StretchModel::continuum;
  if (m.kind == MethodKind::discrete)
    o.vertices = m.resolution;
  else
    o.elements = m.resolution, o.order = m.order;
  if (m.loop) o.element = ContinuumElement::loop;
  if (m.adapted || m.refined) {
    o.mesh = m.adapted ? ContinuumMesh::adapted : ContinuumMesh::refined;
    o.mesh_size_ratio = m.size_ratio;
    o.contact_load = ContinuumLoad::exact_contact;
    o.measure = ContinuumMeasure::quadric_fit;
  }
  auto pick_json = [](const AccuracyPick& p) {
    return nlohmann::json{{"method", method_spec(p.method)},
                          {"symmetry", to_string(p.symmetry)},
                          {"error_percent", 100 * p.error},
                          {"cost_eg", p.cost_eg}};
  };
  o.accuracy_choice = {{"requested_percent", percent},
                       {"chosen", pick_json(ch.chosen)},
                       {"reference_uncertainty_percent", 100 * ch.reference_relative_se},
                       {"table", table.source},
                       {"reason", ch.reason}};
  if (ch.runner_up) o.accuracy_choice["runner_up"] = pick_json(*ch.runner_up);
  if (ch.other_kind) o.accuracy_choice["cheapest_other_model"] = pick_json(*ch.other_kind);
  std::cerr << "rbc: " << ch.reason << "\n";
}

}  // namespace

void add_stretch_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<StretchCli>();
  auto* cmd = app.add_subcommand("stretch", "Optical-tweezers stretch: diameters against force");
  add_config_option(cmd);
  cmd->add_option("--model", o->model, "discrete (spectrin network) | continuum (surface FEM)")
      ->transform(enum_choice<StretchModel>(
          {{"discrete", StretchModel::discrete}, {"continuum", StretchModel::continuum}}))
      ->type_name("TEXT")
      ->default_str("discrete");
  cmd->add_option("--force", o->forces,
                  "comma-separated total bead forces in pN, each in [0, " +
                      format_number(kMaxDiscreteForce_pN) + "] (discrete) or [0, " +
                      format_number(kMaxContinuumForce_pN) + "] (continuum)")
      ->capture_default_str();
  cmd->add_option("--vertices,-n", o->vertices, "discrete: network vertices N (100 to 40,000)")
      ->check(integer_in(100, 40000))
      ->capture_default_str();
  cmd->add_option("--mesh-quality", o->mesh_quality, "phi-minimised | projected | equal-area")
      ->transform(enum_choice<RestMeshQuality>({{"phi-minimised", RestMeshQuality::phi_minimised},
                                                {"projected", RestMeshQuality::projected},
                                                {"equal-area", RestMeshQuality::equal_area}}))
      ->type_name("TEXT")
      ->default_str("phi-minimised");
  cmd->add_option("--mesh-orientation", o->orientation,
                  "dimple-vertex (default: a vertex at each dimple, 4 of the scene's 8 mirrors) | "
                  "mirror-planes (the icosahedron's two-fold axes along x, y, z and bead patches "
                  "cut between x levels: all 8 mirrors, so --symmetry mirror solves one eighth "
                  "of the cell; another triangulation, another discretisation)")
      ->transform(enum_choice<TriangulationOrientation>(
          {{"dimple-vertex", TriangulationOrientation::dimple_vertex},
           {"mirror-planes", TriangulationOrientation::mirror_planes}}))
      ->type_name("TEXT")
      ->default_str("dimple-vertex");
  add_model_options(cmd, o->physics);
  auto* tolerance = cmd->add_option("--tolerance", o->tolerance_pN,
                                    "largest net vertex force at convergence (pN), in (0, 10]")
                        ->default_str("1e-3 (discrete) | 1e-6 (continuum)");
  cmd->add_option("--max-iterations", o->max_iterations,
                  "minimiser iterations per force, in [1, 10000000]")
      ->check(integer_in(1, kMaxIterations))
      ->capture_default_str();
  cmd->add_option("--order", o->order, "continuum: 2 | 3 | 4 | full")
      ->transform(enum_choice<WlcExpansion>({{"2", WlcExpansion::order2},
                                             {"3", WlcExpansion::order3},
                                             {"4", WlcExpansion::order4},
                                             {"full", WlcExpansion::full}}))
      ->type_name("TEXT")
      ->default_str("2");
  cmd->add_option("--symmetry", o->symmetry,
                  "none | mirror (both models): solve on the states symmetric under the mirrors "
                  "the mesh and the bead load share (2 or 4 on the default meshes: |G| times "
                  "fewer unknowns; each symmetric equilibrium is checked and, where it is a "
                  "saddle at which the cell buckles, solved in full); --json points then carry "
                  "symmetry_order and symmetry_broken")
      ->transform(enum_choice<Symmetry>({{"none", Symmetry::none}, {"mirror", Symmetry::mirror}}))
      ->type_name("TEXT")
      ->default_str("none");
  cmd->add_option(
         "--contact-load", o->contact_load,
         "continuum: vertex-patch (the bead force on the nearest vertices, shared by "
         "vertex area) | exact-contact (a uniform traction on the caps of --contact-fraction of "
         "the area, integrated exactly over partial elements: the load moves smoothly "
         "with the mesh)")
      ->transform(enum_choice<ContinuumLoad>({{"vertex-patch", ContinuumLoad::vertex_patch},
                                              {"exact-contact", ContinuumLoad::exact_contact}}))
      ->type_name("TEXT")
      ->default_str("vertex-patch");
  cmd->add_option("--measure", o->measure,
                  "continuum: vertices (D_A, D_T as the extent of the vertices) | quadric-fit "
                  "(the extent of a local quadric fit of the surface at the extremal vertices)")
      ->transform(enum_choice<ContinuumMeasure>({{"vertices", ContinuumMeasure::vertices},
                                                 {"quadric-fit", ContinuumMeasure::quadric_fit}}))
      ->type_name("TEXT")
      ->default_str("vertices");
  cmd->add_option("--symmetry-check", o->symmetry_check_at,
                  "continuum with --symmetry mirror: every-force (each symmetric equilibrium "
                  "is checked as it is solved) | highest-force (only the highest force's, "
                  "after the sweep; if it is a saddle, the sweep runs again with every force "
                  "checked: one check instead of one per force where nothing buckles)")
      ->transform(enum_choice<SymmetryCheckAt>({{"every-force", SymmetryCheckAt::every_force},
                                                {"highest-force", SymmetryCheckAt::highest_force}}))
      ->type_name("TEXT")
      ->default_str("every-force");
  cmd->add_option("--elements", o->elements, "continuum: triangles (200 to 79,996)")
      ->check(integer_in(kMinContinuumElements, kMaxContinuumElements))
      ->capture_default_str();
  cmd->add_option("--element", o->element,
                  "continuum: linear (flat triangles, Juelicher bending; every --mesh, "
                  "--contact-load and --measure) | loop (the C1 Loop subdivision element on the "
                  "uniform mesh: every term on the smooth limit surface, the bead load on the "
                  "caps of its rest surface, D_A and D_T measured on it; no --mesh, "
                  "--contact-load, --measure, --symmetry-check or --warm-start)")
      ->transform(enum_choice<ContinuumElement>(
          {{"linear", ContinuumElement::linear}, {"loop", ContinuumElement::loop}}))
      ->type_name("TEXT")
      ->default_str("linear");
  cmd->add_option("--mesh", o->mesh,
                  "continuum: uniform (Phi-minimised icosphere) | adapted (CGAL surface mesher "
                  "with a size field: fine at the bead-contact rims and the pulled tips, "
                  "--mesh-size-ratio times coarser elsewhere, about --elements triangles; no "
                  "mirror symmetry, so --symmetry mirror solves in full) | refined (the "
                  "icosphere refined by red-green refinement to edges --mesh-size-ratio times "
                  "finer at the bead-contact rims and around the rim points where D_T is "
                  "measured, about --elements triangles; keeps the icosphere's mirrors, so "
                  "--symmetry mirror applies)")
      ->transform(enum_choice<ContinuumMesh>({{"uniform", ContinuumMesh::uniform},
                                              {"adapted", ContinuumMesh::adapted},
                                              {"refined", ContinuumMesh::refined}}))
      ->type_name("TEXT")
      ->default_str("uniform");
  cmd->add_option("--mesh-size-ratio", o->mesh_size_ratio,
                  "continuum with --mesh adapted or refined: coarse / fine edge length, in [1, "
                  "10]")
      ->capture_default_str();
  cmd->add_option("--mesh-seed", o->mesh_seed,
                  "continuum with --mesh adapted: turns the mesher's initial points by a random "
                  "rotation drawn from this seed (0: unturned), giving another triangulation of "
                  "the same size field; same seed, same mesh; with --mesh refined: turns the "
                  "coarse icosphere the same way (the unturned mesh's icosphere for the same "
                  "--elements; a turned mesh keeps no mirror of the scene)")
      ->check(integer_in(0, 1000000))
      ->capture_default_str();
  cmd->add_option("--mesh-volume", o->mesh_volume,
                  "continuum with --mesh refined: surface (every vertex on the Evans-Fung "
                  "surface; the polyhedron encloses slightly less) | scale (scaled about the "
                  "centre to enclose the Evans-Fung volume, as the uniform meshes are, which "
                  "moves the fine rims off the surface by the coarse regions' deficit)")
      ->transform(
          enum_choice<MeshVolume>({{"surface", MeshVolume::surface}, {"scale", MeshVolume::scale}}))
      ->type_name("TEXT")
      ->default_str("surface");
  cmd->add_option("--out", o->out,
                  "write per-force HDF5/XDMF shapes, stretch.csv and run.json (must be empty "
                  "unless --force-overwrite)")
      ->check(nonempty_path());
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("!--no-picture", o->picture,
                "with --out: no cells.png (the shapes at the first and the largest force, "
                "drawn as rbc render draws them)");
  cmd->add_option("--warm-start", o->warm_start,
                  "re-solve each force from the equilibria of an earlier `stretch --out DIR` "
                  "(same model, mesh and forces; e.g. after a small parameter change)");
  cmd->add_flag("--json", o->json,
                "print the run on stdout as JSON: {command, config, provenance, points: [...]}");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  add_verbose_flag(cmd, o->verbose);
  cmd->add_option(
      "--accuracy", o->accuracy,
      "choose the cheapest model and resolution whose accuracy over the forces "
      "meets this percentage (e.g. 1%), from data/tradeoff/accuracy_by_force.csv "
      "and the adapted- and refined-mesh rows beside it (accuracy_by_force_adapted.csv, "
      "accuracy_by_force_refined.csv; left out when --contact-load or --measure is "
      "given), and the Loop element's rows (accuracy_by_force_loop.csv; left out likewise); "
      "excludes --model, --vertices, --elements, --order, --element, --mesh, "
      "--mesh-size-ratio; also chooses --symmetry unless it is given");
  cmd->callback([o, &action, tolerance, cmd] {
    o->tolerance_given = tolerance->count() > 0;
    std::string explicit_choice;  // the first method option given with --accuracy
    for (const char* name : {"--model", "--vertices", "--elements", "--order", "--element",
                             "--mesh", "--mesh-size-ratio"})
      if (explicit_choice.empty() && cmd->get_option(name)->count() > 0) explicit_choice = name;
    const bool accuracy_given = cmd->get_option("--accuracy")->count() > 0;
    const bool symmetry_given = cmd->get_option("--symmetry")->count() > 0;
    const bool check_given = cmd->get_option("--symmetry-check")->count() > 0;
    std::string changed_physics;  // options that leave the table's default physics
    std::vector<std::string> physics = model_option_flags();
    for (const char* name : {"--mesh-quality", "--mesh-orientation", "--tolerance"})
      physics.push_back(name);
    for (const std::string& name : physics)
      if (cmd->get_option(name)->count() > 0)
        changed_physics += (changed_physics.empty() ? "" : ", ") + name;
    action = [o, cmd, explicit_choice, accuracy_given, symmetry_given, check_given,
              changed_physics]() -> int {
      if (accuracy_given) {
        choose_stretch_method(*o, explicit_choice, symmetry_given,
                              cmd->get_option("--contact-load")->count() > 0 ||
                                  cmd->get_option("--measure")->count() > 0);
        if (!changed_physics.empty()) {
          std::cerr << "rbc: warning: --accuracy: the table was measured with the default "
                       "parameters and tolerances; "
                    << changed_physics << " changes them, so its accuracy is not guaranteed\n";
          o->accuracy_choice["warning"] = "defaults changed by " + changed_physics;
        }
      }
      // --symmetry-check chooses among the continuum's checks of symmetric equilibria: refused
      // where there are none to choose (rather than ignored).
      if (check_given && (o->model != StretchModel::continuum || o->symmetry != Symmetry::mirror))
        throw std::invalid_argument(
            "--symmetry-check applies to --model continuum with --symmetry mirror, got --model " +
            std::string(o->model == StretchModel::continuum ? "continuum" : "discrete") +
            " with --symmetry " + to_string(o->symmetry));
      // --contact-load, --measure and --mesh choose how the continuum applies and measures and
      // what it is meshed with: refused for the network, whose vertices are the junction
      // complexes (rather than ignored).
      for (const char* name : {"--contact-load", "--measure", "--mesh", "--mesh-size-ratio",
                               "--mesh-seed", "--mesh-volume", "--element"})
        if (cmd->get_option(name)->count() > 0 && o->model != StretchModel::continuum)
          throw std::invalid_argument(std::string(name) +
                                      " applies to --model continuum, got --model discrete");
      // The Loop element carries its own load and measure on the limit surface, on the uniform
      // mesh, and checks every symmetric equilibrium: the options that choose otherwise are
      // refused with it (rather than ignored).
      if (o->element == ContinuumElement::loop)
        for (const char* name :
             {"--contact-load", "--measure", "--mesh", "--mesh-size-ratio", "--mesh-seed",
              "--mesh-volume", "--symmetry-check", "--warm-start"})
          if (cmd->get_option(name)->count() > 0)
            throw std::invalid_argument(std::string(name) +
                                        " applies to --element linear, got --element loop");
      if (cmd->get_option("--mesh-size-ratio")->count() > 0 && o->mesh == ContinuumMesh::uniform)
        throw std::invalid_argument(
            "--mesh-size-ratio applies to --mesh adapted or refined, got --mesh uniform");
      if (cmd->get_option("--mesh-volume")->count() > 0 && o->mesh != ContinuumMesh::refined)
        throw std::invalid_argument(
            "--mesh-volume applies to --mesh refined, got --mesh " +
            std::string(o->mesh == ContinuumMesh::uniform ? "uniform" : "adapted"));
      if (cmd->get_option("--mesh-seed")->count() > 0 && o->mesh == ContinuumMesh::uniform)
        throw std::invalid_argument(
            "--mesh-seed applies to --mesh adapted or refined, got --mesh uniform");
      if (o->mesh == ContinuumMesh::adapted && cmd->get_option("--mesh-orientation")->count() > 0)
        throw std::invalid_argument(
            "--mesh-orientation applies to --mesh uniform, got --mesh adapted");
      o->record = run_record(*cmd);
      make_cancellable();  // polls interrupt_check(): see app/interrupt.hpp
      return naming_options(stretch_option_names(), [&]() -> int {
        return o->model == StretchModel::discrete ? run_discrete(*o) : run_continuum(*o);
      });
    };
  });
}

}  // namespace rbc::app
