// rbc: multiscale red blood cell mechanics (Hartmann 2008). One executable, one
// sub-command per job; see app/commands.hpp for the exit-code contract.
#include <iostream>
#include <stdexcept>

#include "app/commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"rbc - multiscale red blood cell membrane mechanics (Hartmann 2008 model)"};
  app.require_subcommand(1, 1);
  app.fallthrough(false);
  rbc::app::Action action;
  rbc::app::add_mesh_command(app, action);
  rbc::app::add_stretch_command(app, action);
  rbc::app::add_relax_command(app, action);
  rbc::app::add_bench_command(app, action);
  rbc::app::add_fig7_command(app, action);
  rbc::app::add_tradeoff_command(app, action);
  rbc::app::add_stability_command(app, action);
  rbc::app::add_report_command(app, action);
  rbc::app::add_mc_command(app, action);
  rbc::app::add_moduli_command(app, action);
  rbc::app::add_psi_command(app, action);
  rbc::app::add_infer_command(app, action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "rbc: error: " << e.what() << " (see rbc --help)\n";
    return 2;
  }
  try {
    return action ? action() : 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << "rbc: error: " << e.what() << "\n";
    return 2;
  } catch (const std::runtime_error& e) {
    std::cerr << "rbc: error: " << e.what() << "\n";
    return 2;
  }
}
