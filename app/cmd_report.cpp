// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc stability` and `rbc report`.
#include <cmath>
#include <iostream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/run_config.hpp"
#include "compare/experiment.hpp"
#include "compare/report.hpp"
#include "continuum/continuum_model.hpp"

namespace rbc::app {

void check_output_directory(const std::string& dir, bool overwrite);  // cmd_fig7.cpp

void add_stability_command(CLI::App& app, Action& action) {
  struct Opts {
    StabilityOptions s;
    std::string out = "results/stability";
    bool no_continuum = false, overwrite = false, quiet = false, verbose = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("stability", "Where each method stops working (sweeps)");
  add_config_option(cmd);
  cmd->add_option("--vertices", o->s.discrete_vertices,
                  "discrete network for the sweeps (100 to 40,000)")
      ->check(integer_in(100, 40000))
      ->capture_default_str();
  cmd->add_option("--elements", o->s.continuum_elements,
                  "continuum mesh for the sweeps (200 to 79,996)")
      ->check(integer_in(kMinContinuumElements, kMaxContinuumElements))
      ->capture_default_str();
  cmd->add_flag("--no-continuum", o->no_continuum, "discrete sweeps only");
  cmd->add_option("--out", o->out, "output directory")->capture_default_str();
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  add_verbose_flag(cmd, o->verbose);
  cmd->callback([o, cmd, &action] {
    action = [o, cmd]() -> int {
      const nlohmann::json record = run_record(*cmd);
      check_output_directory(o->out, o->overwrite);
      o->s.include_continuum = !o->no_continuum;
      const StabilityResult r = run_stability(o->s, nullptr, stderr_progress(o->quiet, o->verbose));
      write_stability(r, o->out);
      write_run_record(o->out, record);
      for (const auto& row : r.rows)
        std::cout << to_string(row.study) << " | " << row.method << " | " << row.parameter << " "
                  << row.parameter_value << " | " << to_string(row.metric) << " = "
                  << (row.value ? std::to_string(*row.value) : std::string("not reached")) << "\n";
      std::cout << "outputs: " << o->out
                << "/stability.csv, stability.json, stability_orders.png\n";
      return 0;
    };
  });
}

void add_report_command(CLI::App& app, Action& action) {
  struct Opts {
    std::string out = "results/report";
    bool overwrite = false, quiet = false, verbose = false, quick = false;
    std::string calibration;  ///< cached `rbc infer --out` results (empty: data/calibration)
    bool calibration_only = false, no_calibration = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("report", "Fig. 7 + trade-off + stability in DIR/report.md");
  add_config_option(cmd);
  cmd->add_option("--out", o->out, "output directory")->capture_default_str();
  cmd->add_flag("--quick", o->quick,
                "small resolutions (minutes, not the full study; for a first look)");
  cmd->add_option("--calibration", o->calibration,
                  "cached calibration results: DIR/index.json and the `rbc infer --out` "
                  "directories it names (default: data/calibration)");
  cmd->add_flag("--calibration-only", o->calibration_only,
                "only the calibration section, from the cache (seconds; runs no study)");
  cmd->add_flag("--no-calibration", o->no_calibration, "leave the calibration section out");
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  add_verbose_flag(cmd, o->verbose);
  cmd->callback([o, cmd, &action] {
    action = [o, cmd]() -> int {
      const nlohmann::json record = run_record(*cmd);
      if (o->calibration_only && o->no_calibration)
        throw std::invalid_argument("--calibration-only and --no-calibration exclude each other");
      const std::string cache =
          o->calibration.empty() ? default_data_directory() + "/calibration" : o->calibration;
      // A missing or corrupt cache: exit 2 before anything is written or run.
      if (!o->no_calibration) (void)read_calibration_cache(cache);
      check_output_directory(o->out, o->overwrite);
      if (o->calibration_only) {
        run_calibration_report(cache, o->out);
        write_run_record(o->out, record);
        std::cout << "report: " << o->out << "/report.md (calibration section)\n";
        return 0;
      }
      ReportOptions ro;
      ro.calibration_cache = cache;
      ro.include_calibration = !o->no_calibration;
      if (o->quick) {
        ro.tradeoff.discrete_vertices = {250, 500, 1000, 2000, 4000};
        ro.tradeoff.continuum_elements = {500, 1000, 2000, 4000};
        ro.stability.discrete_vertices = 500;
        ro.stability.continuum_elements = 1000;
        ro.mc_convergence.mc_budget_s = 10.0;
      } else {
        ro.mc_convergence.mc_budget_s = 30.0;
      }
      ro.mc_convergence.vertices = 500;
      run_report(ro, o->out, stderr_progress(o->quiet, o->verbose));
      write_run_record(o->out, record);
      std::cout << "report: " << o->out << "/report.md (figures and CSVs beside it)\n";
      return 0;
    };
  });
}

}  // namespace rbc::app
