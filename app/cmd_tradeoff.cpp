// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc tradeoff`: accuracy against wall time for every method and resolution.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/model_options.hpp"
#include "app/run_config.hpp"
#include "compare/accuracy_study.hpp"
#include "compare/mc_convergence.hpp"
#include "compare/tradeoff.hpp"
#include "continuum/continuum_model.hpp"
#include "core/validation.hpp"

namespace rbc::app {

void check_output_directory(const std::string& dir, bool overwrite);  // cmd_fig7.cpp
void check_method_forces(const std::vector<Method>& methods,
                         const std::vector<double>& forces_pN);  // cmd_fig7.cpp

namespace {

/// The time-to-accuracy table of the Monte Carlo study, one accuracy level per line.
void print_time_to_accuracy(const McConvergenceResult& r) {
  const auto& o = r.options;
  std::cout << std::defaultfloat << std::setprecision(6) << "time to accuracy at " << o.force_pN
            << " pN, N = " << r.vertices << ": reference D_A " << r.reference.axial_um
            << " um (minimiser at " << r.reference.force_tolerance_pN << " pN); Monte Carlo at "
            << o.mc_temperature_K << " K (step adapting to " << o.mc_target_acceptance
            << " acceptance) for " << r.mc_wall_s << " s, "
            << (r.mc.empty() ? 0 : r.mc.back().sweeps) << " sweeps\n"
            << "  accuracy  level_um   minimiser_s        mc_s   mc_sweeps  mc/minimiser\n";
  auto cell = [](const auto& v, int width, int digits) {
    std::ostringstream s;
    if (v)
      s << std::fixed << std::setprecision(digits) << *v;
    else
      s << "-";
    return std::string(std::max(0, width - static_cast<int>(s.str().size())), ' ') + s.str();
  };
  for (const auto& t : r.time_to_accuracy)
    std::cout << std::fixed << std::setprecision(1) << std::setw(8) << 100 * t.relative << " %"
              << std::setprecision(4) << std::setw(10) << t.level_um << cell(t.minimiser_s, 14, 3)
              << cell(t.mc_s, 12, 3) << cell(t.mc_sweeps, 12, 0) << cell(t.ratio(), 14, 2) << "\n";
  if (std::any_of(r.time_to_accuracy.begin(), r.time_to_accuracy.end(),
                  [](const TimeToAccuracy& t) { return !t.ratio(); }))
    std::cout << "  (- = not reached: minimiser at the tolerances tried, Monte Carlo in "
              << std::defaultfloat << o.mc_budget_s << " s)\n";
  std::cout << mc_convergence_conclusion(r) << "\n";
}

/// The check of a coarse / fine size ratio of a graded mesh: a number in [1, 10].
CLI::Validator size_ratio_validator() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const std::optional<double> r = parse_finite_number(text);
        return r && *r >= 1 && *r <= 10 ? "" : text + ": expected a number in [1, 10]";
      },
      "RATIO");
}

}  // namespace

void add_tradeoff_command(CLI::App& app, Action& action) {
  struct Opts {
    double force = 88.0;
    std::vector<int> vertices, elements;
    std::vector<std::string> orders;
    bool no_continuum = false, overwrite = false, quiet = false, verbose = false;
    int mc_vertices = 500;
    double mc_budget = 20.0, mc_acceptance = McConvergenceOptions{}.mc_target_acceptance;
    std::string out = "results/tradeoff";
    // --accuracy-table: the 13-force accuracy-cost study (data/tradeoff/).
    bool accuracy_table = false, runs_only = false;
    std::vector<unsigned> reference_seeds = AccuracyStudyOptions{}.reference_seeds;
    std::vector<unsigned> spread_seeds = AccuracyStudyOptions{}.spread_seeds;
    int reference_vertices = AccuracyStudyOptions{}.reference_vertices;
    double reference_tolerance = AccuracyStudyOptions{}.reference_force_tolerance_pN;
    int spread_max = AccuracyStudyOptions{}.spread_max_resolution;
    std::vector<Symmetry> symmetries = AccuracyStudyOptions{}.symmetries;
    std::string cache;
    // The adapted-mesh rows of the table (accuracy_cost_adapted.csv).
    std::vector<int> adapted_elements = {500, 1000, 2000, 4000, 8000};
    std::vector<double> adapted_ratios = {2.0, 3.0};
    int adapted_seeds = AccuracyStudyOptions{}.adapted_seeds;
    bool no_adapted = false;
    // The refined-mesh rows of the table (accuracy_cost_refined.csv).
    std::vector<int> refined_elements = {500, 1000, 1500, 2000, 2900, 4000, 4500, 6500, 8000};
    std::vector<double> refined_ratios = {1.0, 2.0, 3.0};
    bool no_refined = false;
    // The Loop element's rows of the table (accuracy_cost_loop.csv).
    std::vector<int> loop_elements = {500, 980, 2000};
    bool no_loop = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("tradeoff", "Accuracy against wall time, with the Pareto front");
  add_config_option(cmd);
  cmd->add_option("--force", o->force, "total bead force (pN)")->capture_default_str();
  cmd->add_option("--vertices", o->vertices,
                  "discrete network sizes, 100 to 40,000 (default 250 500 1000 2000 4000 8000 "
                  "16000 27500)")
      ->check(integer_in(100, 40000))
      ->delimiter(',');
  cmd->add_option("--elements", o->elements,
                  "continuum mesh sizes, 200 to 79,996 (default 500 1000 2000 4000 8000 16000)")
      ->check(integer_in(kMinContinuumElements, kMaxContinuumElements))
      ->delimiter(',');
  cmd->add_option("--orders", o->orders, "continuum orders 2, 3, 4, full (default 2,full)")
      ->check(CLI::IsMember({"2", "3", "4", "full"}))
      ->delimiter(',');
  cmd->add_flag("--no-continuum", o->no_continuum, "discrete networks only");
  cmd->add_option("--mc-vertices", o->mc_vertices,
                  "network for the time-to-accuracy study, Monte Carlo against the minimiser "
                  "(100 to 40,000)")
      ->check(integer_in(100, 40000))
      ->capture_default_str();
  cmd->add_option("--mc-budget", o->mc_budget,
                  "wall-clock budget of that study's Monte Carlo chain (s, at most 86400; 0 = "
                  "skip the study)")
      ->capture_default_str();
  cmd->add_option("--mc-acceptance", o->mc_acceptance,
                  "acceptance the quench's trial step adapts to, in (0, 0.5): at 0 K it cannot "
                  "exceed 0.5")
      ->capture_default_str();
  cmd->add_option("--out", o->out, "output directory")->capture_default_str();
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  add_verbose_flag(cmd, o->verbose);
  cmd->add_flag("--accuracy-table", o->accuracy_table,
                "instead: the accuracy-cost table over the 13 forces of the stretch data (0-193 "
                "pN) against the "
                "full-level reference (what `rbc stretch --accuracy` reads; regenerate "
                "data/tradeoff/ with --out data/tradeoff --force-overwrite). Uses --vertices, "
                "--elements, --orders (defaults here: vertices 250,500,1000,2000,4000,8000,16000; "
                "elements 500,980,2000,3920,8000,15680,32000; orders 2,full, the full law up "
                "to 8,000 elements); the forces are those of the stretch data");
  cmd->add_option("--reference-seeds", o->reference_seeds,
                  "--accuracy-table: triangulation rotations of the reference (0 = default "
                  "mesh; default 0,1,2,3,4)")
      ->delimiter(',');
  cmd->add_option("--spread-seeds", o->spread_seeds,
                  "--accuracy-table: extra rotations of every size up to --spread-max (default "
                  "1,2,3)")
      ->delimiter(',');
  cmd->add_option("--spread-max", o->spread_max,
                  "--accuracy-table: largest size (vertices or elements) given the extra "
                  "rotations")
      ->check(integer_in(0, 80000))
      ->capture_default_str();
  cmd->add_option("--reference-vertices", o->reference_vertices,
                  "--accuracy-table: reference network size, 100 to 40,000")
      ->check(integer_in(100, 40000))
      ->capture_default_str();
  cmd->add_option("--reference-tolerance", o->reference_tolerance,
                  "--accuracy-table: force tolerance of the reference sweeps (pN per vertex, 1e-8 "
                  "to 1e-3; the table's entries keep the methods' default 1e-3 pN)")
      ->capture_default_str();
  cmd->add_option("--symmetries", o->symmetries,
                  "--accuracy-table: solver paths each default-mesh sweep is run with, none or "
                  "none,mirror (default none,mirror: every method at its best; a mirror row has "
                  "its full row's mesh, its own sweep's errors and its own cost)")
      ->transform(enum_choice<Symmetry>({{"none", Symmetry::none}, {"mirror", Symmetry::mirror}}))
      ->type_name("TEXT")
      ->delimiter(',');
  cmd->add_option("--cache", o->cache,
                  "--accuracy-table: directory of per-sweep CSV files, reused when present "
                  "(default OUT/runs)");
  cmd->add_option("--adapted-elements", o->adapted_elements,
                  "--accuracy-table: element counts of the continuum rows on the adapted mesh "
                  "(full law, exact contact load, quadric-fit diameters; written to "
                  "accuracy_cost_adapted.csv), 200 to 79,996 (default 500,1000,2000,4000,8000)")
      ->check(integer_in(kMinContinuumElements, kMaxContinuumElements))
      ->delimiter(',');
  cmd->add_option("--adapted-ratios", o->adapted_ratios,
                  "--accuracy-table: coarse / fine size ratios of the adapted rows, each in [1, "
                  "10] (default 2,3)")
      ->check(size_ratio_validator())
      ->delimiter(',');
  cmd->add_option("--adapted-seeds", o->adapted_seeds,
                  "--accuracy-table: mesh seeds 0 .. K-1 of each adapted row, its errors the "
                  "worst over them (the analogue of the icosphere's rotations), 1 to 64")
      ->check(integer_in(1, 64))
      ->capture_default_str();
  cmd->add_flag("--no-adapted", o->no_adapted, "--accuracy-table: no adapted-mesh rows");
  cmd->add_option(
         "--refined-elements", o->refined_elements,
         "--accuracy-table: element counts of the continuum rows on the refined mesh "
         "(full law, exact contact load, quadric-fit diameters, both solver paths, the "
         "rotations of --spread-seeds; written to accuracy_cost_refined.csv), 200 to "
         "79,996 (default 500,1000,1500,2000,2900,4000,4500,6500,8000; a count whose mesh is "
         "one already swept at the ratio is left out)")
      ->check(integer_in(kMinContinuumElements, kMaxContinuumElements))
      ->delimiter(',');
  cmd->add_option("--refined-ratios", o->refined_ratios,
                  "--accuracy-table: coarse / fine size ratios of the refined rows, each in [1, "
                  "10] (default 1,2,3; 1: the icosphere itself, refined only where a triangle "
                  "is larger than its mean)")
      ->check(size_ratio_validator())
      ->delimiter(',');
  cmd->add_flag("--no-refined", o->no_refined, "--accuracy-table: no refined-mesh rows");
  cmd->add_option("--loop-elements", o->loop_elements,
                  "--accuracy-table: element counts of the continuum rows on the C1 Loop "
                  "element (full law, load and diameters on the limit surface, both solver "
                  "paths, the rotations of --spread-seeds; written to accuracy_cost_loop.csv), "
                  "200 to 79,996 (default 500,980,2000)")
      ->check(integer_in(kMinContinuumElements, kMaxContinuumElements))
      ->delimiter(',');
  cmd->add_flag("--no-loop", o->no_loop, "--accuracy-table: no Loop-element rows");
  cmd->add_flag("--runs-only", o->runs_only,
                "--accuracy-table: only run (and cache) the sweeps, write no table");
  auto physics = std::make_shared<ModelCli>();
  add_model_options(cmd, *physics);
  cmd->callback([o, physics, cmd, &action] {
    std::string changed_physics;  // model options given: the accuracy table is measured without
    for (const std::string& name : model_option_flags())
      if (changed_physics.empty() && cmd->get_option(name)->count() > 0) changed_physics = name;
    action = [o, physics, cmd, changed_physics]() -> int {
      const NetworkParameters parameters = checked_network_parameters(*physics);
      const nlohmann::json record = run_record(*cmd);
      if (o->accuracy_table && !changed_physics.empty())
        throw std::invalid_argument(
            "--accuracy-table is measured at the default physics (its reference and cached "
            "sweeps are), got " +
            changed_physics + " " + cmd->get_option(changed_physics)->results().front());
      if (o->accuracy_table) {
        AccuracyStudyOptions ao;
        if (!o->vertices.empty()) ao.discrete_vertices = o->vertices;
        if (!o->elements.empty()) ao.continuum_elements = o->elements;
        if (!o->orders.empty()) {
          ao.continuum_orders.clear();
          for (const auto& s : o->orders)
            ao.continuum_orders.push_back(wlc_expansion_from_string(s));
        }
        ao.adapted_elements = o->adapted_elements;
        ao.adapted_size_ratios = o->adapted_ratios;
        ao.adapted_seeds = o->adapted_seeds;
        if (o->no_continuum) ao.continuum_elements.clear();
        if (o->no_continuum || o->no_adapted) ao.adapted_elements.clear();
        ao.refined_elements = o->refined_elements;
        ao.refined_size_ratios = o->refined_ratios;
        if (o->no_continuum || o->no_refined) ao.refined_elements.clear();
        ao.loop_elements = o->loop_elements;
        if (o->no_continuum || o->no_loop) ao.loop_elements.clear();
        ao.reference_seeds = o->reference_seeds;
        ao.spread_seeds = o->spread_seeds;
        ao.spread_max_resolution = o->spread_max;
        ao.reference_vertices = o->reference_vertices;
        ao.reference_force_tolerance_pN = o->reference_tolerance;
        ao.symmetries = o->symmetries;
        ao.cache_dir = o->cache.empty() ? o->out + "/runs" : o->cache;
        naming_options({{"accuracy study", "--reference-seeds"}}, [&] {
          ao.validate();
          return 0;
        });
        if (!o->runs_only) check_output_directory(o->out, o->overwrite);
        if (o->runs_only) {
          run_accuracy_sweeps(ao, stderr_progress(o->quiet, o->verbose));
          std::cout << "sweeps cached in " << ao.cache_dir << "\n";
          return 0;
        }
        const AccuracyStudy st = run_accuracy_study(ao, stderr_progress(o->quiet, o->verbose));
        write_accuracy_study(st, o->out);
        write_run_record(o->out, record);
        std::cout << std::defaultfloat << std::setprecision(4);
        for (const auto& r : st.rows)
          std::cout << "  " << std::left << std::setw(52)
                    << r.method.label() + (r.symmetry == Symmetry::mirror ? ", mirror" : "")
                    << std::right << " error " << 100 * r.error_all << " % (low "
                    << 100 * r.error_low << ", mid " << 100 * r.error_mid << ", high "
                    << 100 * r.error_high << "), cost " << r.cost_eg << " evaluations"
                    << (r.converged ? "" : "  NOT CONVERGED") << "\n";
        std::cout << accuracy_study_verdict(st);
        std::cout << "outputs: " << o->out
                  << "/accuracy_cost.csv, accuracy_by_force.csv, reference.csv, "
                     "richardson.csv, convergence.csv, accuracy_cost.png, "
                     "accuracy_resolution.png"
                  << (ao.adapted_elements.empty()
                          ? ""
                          : ", accuracy_cost_adapted.csv, accuracy_by_force_adapted.csv, "
                            "convergence_adapted.csv, orders_adapted.csv, richardson_adapted.csv")
                  << (ao.refined_elements.empty()
                          ? ""
                          : ", accuracy_cost_refined.csv, accuracy_by_force_refined.csv, "
                            "convergence_refined.csv, orders_refined.csv")
                  << (ao.loop_elements.empty()
                          ? ""
                          : ", accuracy_cost_loop.csv, accuracy_by_force_loop.csv, "
                            "convergence_loop.csv, orders_loop.csv")
                  << "\n";
        return 0;
      }
      TradeoffOptions to;
      to.parameters = parameters;
      to.provenance = record_comment_lines(record);
      to.force_pN = o->force;
      if (!o->vertices.empty()) to.discrete_vertices = o->vertices;
      if (!o->elements.empty()) to.continuum_elements = o->elements;
      if (!o->orders.empty()) {
        to.continuum_orders.clear();
        for (const auto& s : o->orders) to.continuum_orders.push_back(wlc_expansion_from_string(s));
      }
      to.include_continuum = !o->no_continuum;
      McConvergenceOptions mo;
      mo.force_pN = o->force;
      mo.parameters = parameters;
      mo.vertices = o->mc_vertices;
      mo.mc_budget_s = o->mc_budget;
      mo.mc_target_acceptance = o->mc_acceptance;
      // Bad input fails before the long runs: forces within every method's range, the study.
      std::vector<Method> methods;
      for (int n : to.discrete_vertices) methods.push_back({MethodKind::discrete, n});
      if (to.include_continuum && !to.continuum_elements.empty())
        for (WlcExpansion order : to.continuum_orders)
          methods.push_back({MethodKind::continuum, to.continuum_elements.front(), order});
      check_method_forces(methods, {o->force});
      if (o->mc_budget != 0)
        naming_options({{"force (discrete model)", "--force"},
                        {"Monte Carlo study vertices", "--mc-vertices"},
                        {"Monte Carlo budget", "--mc-budget"},
                        {"Monte Carlo target acceptance at 0 K", "--mc-acceptance"}},
                       [&] {
                         mo.validate();
                         return 0;
                       });
      check_output_directory(o->out, o->overwrite);
      const TradeoffResult r = run_tradeoff(to, stderr_progress(o->quiet, o->verbose));
      write_tradeoff(r, o->out);
      write_run_record(o->out, record);
      std::cout << "reference at " << r.force_pN << " pN: D_A "
                << format_with_error(r.reference.axial_um, r.reference.axial_error_um)
                << " um, D_T "
                << format_with_error(r.reference.transverse_um, r.reference.transverse_error_um)
                << " um (" << r.reference.how << ")\n";
      for (const auto& row : r.rows)
        std::cout << "  " << std::left << std::setw(44) << row.run.method.label() << std::right
                  << std::fixed << std::setprecision(3) << " D_A " << row.axial_um << " (err "
                  << row.axial_error_um << "), D_T " << row.transverse_um << " (err "
                  << row.transverse_error_um << "), " << std::setprecision(2) << row.wall_s << " s"
                  << (row.pareto ? "  [Pareto]" : "") << (row.converged ? "" : "  NOT CONVERGED")
                  << "\n";
      std::cout << "outputs: " << o->out
                << "/tradeoff.csv, tradeoff_axial.png, tradeoff_transverse.png\n";
      if (o->mc_budget == 0) return 0;
      const McConvergenceResult mc = run_mc_convergence(mo, stderr_progress(o->quiet, o->verbose));
      write_mc_convergence(mc, o->out);
      print_time_to_accuracy(mc);
      std::cout << "outputs: " << o->out << "/mc_convergence.csv, mc_convergence.json, "
                << "mc_convergence.png\n";
      return 0;
    };
  });
}

}  // namespace rbc::app
