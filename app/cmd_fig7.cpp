// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc fig7`: the paper's Fig. 7 against Mills 2004, with goodness of fit per method.
#include <iomanip>
#include <iostream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/model_options.hpp"
#include "app/run_config.hpp"
#include "compare/fig7.hpp"
#include "continuum/continuum_stretch.hpp"
#include "discrete/stretch.hpp"

namespace rbc::app {

/// --out of the study commands, checked (writable, empty unless --force-overwrite) and created
/// before any computation.
void check_output_directory(const std::string& dir, bool overwrite) {
  prepare_output_directory(dir, overwrite);
}

/// Every force within the documented range of every method that will run (names --force).
void check_method_forces(const std::vector<Method>& methods, const std::vector<double>& forces_pN) {
  naming_options({{"force (discrete model)", "--force"}, {"force (continuum model)", "--force"}},
                 [&] {
                   for (const Method& m : methods)
                     for (double f : forces_pN)
                       m.kind == MethodKind::discrete ? validate_discrete_force(f)
                                                      : validate_continuum_force(f);
                   return 0;
                 });
}

void add_fig7_command(CLI::App& app, Action& action) {
  struct Opts {
    std::string out = "results/fig7";
    std::string forces;
    std::vector<std::string> methods;
    std::string data_dir;
    bool overwrite = false, quiet = false, verbose = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("fig7", "Fig. 7: diameters vs force, models against Mills 2004");
  add_config_option(cmd);
  auto physics = std::make_shared<ModelCli>();
  cmd->add_option("--out", o->out, "output directory (must be empty unless --force-overwrite)")
      ->capture_default_str();
  cmd->add_option(
      "--force", o->forces,
      "increasing comma-separated forces in pN (default: Mills forces, then 220, 250, 300)");
  cmd->add_option("--method", o->methods,
                  "methods to run, repeatable: discrete:N or continuum:ORDER:ELEMENTS "
                  "(default: discrete:2000 and continuum 2, 3, 4, full at 4000 elements)");
  cmd->add_option("--data", o->data_dir, "directory with the Mills CSV files (default: data/)");
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  add_verbose_flag(cmd, o->verbose);
  add_model_options(cmd, *physics);
  cmd->callback([o, physics, cmd, &action] {
    action = [o, physics, cmd]() -> int {
      Fig7Options fo;
      fo.parameters = checked_network_parameters(*physics);
      const nlohmann::json record = run_record(*cmd);
      fo.provenance = record_comment_lines(record);
      if (!o->forces.empty()) fo.forces_pN = parse_force_list(o->forces);
      check_increasing_forces(fo.forces_pN);
      for (const auto& m : o->methods) fo.methods.push_back(parse_method(m));
      fo.data_dir = o->data_dir;
      check_method_forces(fo.methods.empty() ? default_fig7_methods() : fo.methods, fo.forces_pN);
      check_output_directory(o->out, o->overwrite);
      const Fig7Result r = run_fig7(fo, stderr_progress(o->quiet, o->verbose));
      write_fig7(r, o->out);
      write_run_record(o->out, record);
      std::cout << "goodness of fit against Mills 2004 (0-193 pN, " << r.experiment.size()
                << " points):\n";
      for (size_t k = 0; k < r.runs.size(); ++k) {
        const auto& q = r.fits[k];
        std::cout << "  " << std::left << std::setw(44) << r.runs[k].method.label() << std::right
                  << std::fixed << std::setprecision(2) << " D_A rms " << q.axial_rms_um << " um ("
                  << q.axial_inside << "/" << q.points << " inside), D_T rms "
                  << q.transverse_rms_um << " um (" << q.transverse_inside << "/" << q.points
                  << " inside), " << std::setprecision(1) << r.runs[k].total_s << " s"
                  << (r.runs[k].all_converged() ? "" : "  NOT CONVERGED") << "\n";
      }
      std::cout << "outputs: " << o->out << "/fig7.png, fig7_fit.csv, fig7_*.csv, fig7.json\n";
      for (const auto& run : r.runs)
        if (!run.all_converged()) return 1;
      return 0;
    };
  });
}

}  // namespace rbc::app
