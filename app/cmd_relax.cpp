// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc relax`: Canham-Helfrich relaxation of the Evans-Fung rest shape at fixed area and
// volume, in-plane elasticity off (paper Sec. 5.3.1, Fig. 5; Li et al. 2005): how far is
// the measured shape from a bending minimiser, for each spontaneous curvature H0?
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/model_options.hpp"
#include "app/run_config.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/relax.hpp"
#include "core/io.hpp"
#include "core/lbfgs.hpp"
#include "core/validation.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc::app {

namespace {

struct RelaxCli {
  int elements = 2000;
  std::string h0_list = "0,0.1";
  ModelCli physics;  ///< the model option group: kappa, and the regulariser's WLC and steric law
  double regulariser = 1e-2;
  double tolerance_pN = 1e-6;
  int max_iterations = 200;
  std::string out;
  bool json = false, quiet = false, verbose = false, overwrite = false;
  nlohmann::json record;  ///< what produced the run (app/run_config.hpp)
};

/// Library quantities -> this command's options.
const OptionNames kRelaxOptionNames = {
    {"spontaneous curvature H0", "--h0"},
    {"regulariser (fraction of the p=2 law)", "--regulariser"},
    {"force tolerance", "--tolerance"},
    {"max iterations", "--max-iterations"},
};

/// Parses "0,0.1" (1/um); negative values are allowed (H0 has a sign).
std::vector<double> parse_h0_list(const std::string& text) {
  return parse_number_list(text, "--h0", "0,0.1 in 1/um", true);
}

int run_relax(const RelaxCli& o) {
  const std::vector<double> h0s = parse_h0_list(o.h0_list);
  const NetworkParameters physics = checked_network_parameters(o.physics);
  for (double h0 : h0s) BendingParameters{physics.bending.kappa_pNum, h0}.validate();
  require_finite_in_range("regulariser (fraction of the p=2 law)", "", o.regulariser, 0.0, 1.0);
  NewtonOptions no;
  no.force_tolerance_pN = o.tolerance_pN;
  no.max_iterations = o.max_iterations;
  no.validate();
  if (!o.out.empty()) {
    require_distinct(h0s, "--h0", o.h0_list);
    prepare_output_directory(o.out, o.overwrite);
  }
  const ProgressSink progress = stderr_progress(o.quiet, o.verbose);
  MeshQualityReport mr;
  const TriMesh mesh = make_continuum_mesh(o.elements, {}, &mr);
  report(progress, "Evans-Fung mesh: " + std::to_string(mr.vertices) + " vertices, " +
                       std::to_string(mr.faces) + " elements");
  const IsotropicMembraneLaw reg = scaled_law(
      make_membrane_law(physics.wlc, physics.steric, WlcExpansion::order2), o.regulariser);
  nlohmann::json rows = nlohmann::json::array();
  CsvTable csv;
  csv.comments = {
      "rbc relax: Canham-Helfrich relaxation of the Evans-Fung shape at fixed A, V",
      "units: H0 1/um, lengths um, energy pN*um; regulariser = fraction of the p=2 law",
      "elements " + std::to_string(mr.faces) + ", regulariser " + std::to_string(o.regulariser)};
  const std::vector<std::string> record_lines = record_comment_lines(o.record);
  csv.header = {"h0_per_um",
                "largest_displacement_um",
                "diameter_before_um",
                "diameter_after_um",
                "thickness_centre_before_um",
                "thickness_centre_after_um",
                "thickness_rim_before_um",
                "thickness_rim_after_um",
                "helfrich_before_pNum",
                "helfrich_after_pNum",
                "regulariser_pNum",
                "iterations",
                "converged",
                "residual_pN",
                "wall_s"};
  int status = 0;
  for (double h0 : h0s) {
    report(progress, "relaxing with H0 = " + std::to_string(h0) + " per um");
    const RelaxResult r = relax_helfrich(mesh, {physics.bending.kappa_pNum, h0}, reg, no, progress);
    rows.push_back({{"h0_per_um", h0},
                    {"largest_displacement_um", r.largest_displacement_um},
                    {"diameter_before_um", r.before.diameter_um},
                    {"diameter_after_um", r.after.diameter_um},
                    {"thickness_centre_before_um", r.before.thickness_centre_um},
                    {"thickness_centre_after_um", r.after.thickness_centre_um},
                    {"thickness_rim_before_um", r.before.thickness_rim_um},
                    {"thickness_rim_after_um", r.after.thickness_rim_um},
                    {"helfrich_before_pNum", r.energy_before_pNum},
                    {"helfrich_after_pNum", r.energy_after_pNum},
                    {"regulariser_pNum", r.regulariser_energy_pNum},
                    {"iterations", r.solve.iterations},
                    {"converged", r.solve.converged()},
                    {"residual_pN", r.solve.residual_pN},
                    {"area_drift", r.solve.area_drift},
                    {"volume_drift", r.solve.volume_drift},
                    {"elements", mr.faces},
                    {"wall_s", r.wall_s}});
    csv.rows.push_back({h0, r.largest_displacement_um, r.before.diameter_um, r.after.diameter_um,
                        r.before.thickness_centre_um, r.after.thickness_centre_um,
                        r.before.thickness_rim_um, r.after.thickness_rim_um, r.energy_before_pNum,
                        r.energy_after_pNum, r.regulariser_energy_pNum,
                        static_cast<double>(r.solve.iterations), r.solve.converged() ? 1.0 : 0.0,
                        r.solve.residual_pN, r.wall_s});
    if (!o.out.empty()) {
      const std::string tag = number_tag(h0, 3);  // 0.100, or more digits to tell two apart
      const Eigen::VectorXd u = (r.x - mesh.x).colwise().norm().transpose();
      MeshSnapshot s{r.x, mesh.topo.faces,     {{"displacement_um", u}},
                     {},  {{"h0_per_um", h0}}, record_attributes(o.record)};
      write_mesh_snapshot(o.out + "/relaxed_h0_" + tag, s);
    }
    if (!r.solve.converged()) {
      std::cerr << "rbc: error: relaxation with H0 = " + format_number(h0) +
                       " per um did not converge (" + to_string(r.solve.status) +
                       "): largest vertex force residual " +
                       format_scientific(r.solve.residual_pN) + " pN, area drift " +
                       format_scientific(r.solve.area_drift) + ", volume drift " +
                       format_scientific(r.solve.volume_drift) + "\n";
      status = 1;
    }
  }
  if (!o.out.empty()) {
    CsvTable recorded = csv;
    recorded.comments.insert(recorded.comments.end(), record_lines.begin(), record_lines.end());
    write_csv(o.out + "/relax.csv", recorded);
    write_text_atomic(o.out + "/relax.json", rows.dump(2) + "\n");
    write_run_record(o.out, o.record);
  }
  if (o.json) {
    nlohmann::json out = o.record;
    out["points"] = rows;
    std::cout << out.dump(2) << "\n";
  } else {
    std::cout << "# " << csv.comments[2] << "\n"
              << std::setw(8) << "H0" << std::setw(11) << "max_disp" << std::setw(16) << "diameter"
              << std::setw(16) << "centre_thick" << std::setw(16) << "rim_thick" << std::setw(16)
              << "helfrich_pNum" << std::setw(7) << "iter"
              << "\n";
    for (const auto& r : rows) {
      auto pair = [&](const char* a, const char* b) {
        std::ostringstream s;
        s << std::fixed << std::setprecision(3) << r[a].get<double>() << "->" << r[b].get<double>();
        return s.str();
      };
      std::cout << std::fixed << std::setprecision(3) << std::setw(8)
                << r["h0_per_um"].get<double>() << std::setw(11)
                << r["largest_displacement_um"].get<double>() << std::setw(16)
                << pair("diameter_before_um", "diameter_after_um") << std::setw(16)
                << pair("thickness_centre_before_um", "thickness_centre_after_um") << std::setw(16)
                << pair("thickness_rim_before_um", "thickness_rim_after_um") << std::setw(16)
                << pair("helfrich_before_pNum", "helfrich_after_pNum") << std::setw(7)
                << r["iterations"].get<int>() << "\n";
    }
  }
  return status;
}

}  // namespace

void add_relax_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<RelaxCli>();
  auto* cmd = app.add_subcommand(
      "relax", "Helfrich relaxation of the Evans-Fung shape at fixed area and volume (Fig. 5)");
  add_config_option(cmd);
  cmd->add_option("--elements", o->elements, "continuum triangles (200 to 79,996)")
      ->check(integer_in(kMinContinuumElements, kMaxContinuumElements))
      ->capture_default_str();
  cmd->add_option("--h0", o->h0_list,
                  "comma-separated spontaneous curvatures H0 (1/um), each in [-100, 100]")
      ->capture_default_str();
  cmd->add_option("--regulariser", o->regulariser,
                  "in-plane mesh regulariser: fraction of the p=2 membrane law (0, 1]")
      ->capture_default_str();
  cmd->add_option("--tolerance", o->tolerance_pN,
                  "largest net vertex force at convergence (pN), in (0, 10]")
      ->capture_default_str();
  cmd->add_option("--max-iterations", o->max_iterations, "Newton iterations, in [1, 10000000]")
      ->check(integer_in(1, kMaxIterations))
      ->capture_default_str();
  cmd->add_option("--out", o->out,
                  "write relaxed shapes (HDF5/XDMF), relax.csv and relax.json (must be empty "
                  "unless --force-overwrite)")
      ->check(nonempty_path());
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("--json", o->json,
                "print the run on stdout as JSON: {command, config, provenance, points: [...]}");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  add_verbose_flag(cmd, o->verbose);
  add_model_options(cmd, o->physics, {"--h0"});
  cmd->callback([o, cmd, &action] {
    action = [o, cmd]() -> int {
      o->record = run_record(*cmd);
      return naming_options(kRelaxOptionNames, [&] { return run_relax(*o); });
    };
  });
}

}  // namespace rbc::app
