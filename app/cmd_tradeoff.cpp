// `rbc tradeoff`: accuracy against wall time for every method and resolution.
#include <iomanip>
#include <iostream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "compare/tradeoff.hpp"

namespace rbc::app {

void check_output_directory(const std::string& dir, bool overwrite);  // cmd_fig7.cpp

void add_tradeoff_command(CLI::App& app, Action& action) {
  struct Opts {
    double force = 88.0;
    std::vector<int> vertices, elements;
    std::vector<std::string> orders;
    bool no_continuum = false, overwrite = false, quiet = false;
    std::string out = "results/tradeoff";
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("tradeoff", "Accuracy against wall time, with the Pareto front");
  cmd->add_option("--force", o->force, "total bead force (pN)")->capture_default_str();
  cmd->add_option("--vertices", o->vertices,
                  "discrete network sizes (default 250 500 1000 2000 4000 8000 16000 27500)")
      ->delimiter(',');
  cmd->add_option("--elements", o->elements,
                  "continuum mesh sizes (default 500 1000 2000 4000 8000 16000)")
      ->delimiter(',');
  cmd->add_option("--orders", o->orders, "continuum orders (default 2,full)")->delimiter(',');
  cmd->add_flag("--no-continuum", o->no_continuum, "discrete networks only");
  cmd->add_option("--out", o->out, "output directory")->capture_default_str();
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("--quiet", o->quiet, "no progress on stderr");
  cmd->callback([o, &action] {
    action = [o]() -> int {
      TradeoffOptions to;
      to.force_pN = o->force;
      if (!o->vertices.empty()) to.discrete_vertices = o->vertices;
      if (!o->elements.empty()) to.continuum_elements = o->elements;
      if (!o->orders.empty()) {
        to.continuum_orders.clear();
        for (const auto& s : o->orders) to.continuum_orders.push_back(wlc_expansion_from_string(s));
      }
      to.include_continuum = !o->no_continuum;
      check_output_directory(o->out, o->overwrite);
      const TradeoffResult r = run_tradeoff(to, stderr_progress(o->quiet));
      write_tradeoff(r, o->out);
      std::cout << "reference at " << r.force_pN << " pN: D_A " << r.reference.axial_um << " +- "
                << r.reference.axial_error_um << " um, D_T " << r.reference.transverse_um << " +- "
                << r.reference.transverse_error_um << " um (" << r.reference.how << ")\n";
      for (const auto& row : r.rows)
        std::cout << "  " << std::left << std::setw(44) << row.run.method.label() << std::right
                  << std::fixed << std::setprecision(3) << " D_A " << row.axial_um << " (err "
                  << row.axial_error_um << "), D_T " << row.transverse_um << " (err "
                  << row.transverse_error_um << "), " << std::setprecision(2) << row.wall_s << " s"
                  << (row.pareto ? "  [Pareto]" : "") << (row.converged ? "" : "  NOT CONVERGED")
                  << "\n";
      std::cout << "outputs: " << o->out
                << "/tradeoff.csv, tradeoff_axial.png, tradeoff_transverse.png\n";
      return 0;
    };
  });
}

}  // namespace rbc::app
