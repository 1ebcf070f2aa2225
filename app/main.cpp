// rbc: multiscale red blood cell mechanics (Hartmann 2008). One executable, one
// sub-command per job; see app/commands.hpp for the exit-code contract.
#include <malloc.h>

#include <iostream>
#include <stdexcept>
#include <string>

#include "app/commands.hpp"
#include "app/interrupt.hpp"
#include "core/progress.hpp"

namespace {

/// glibc malloc: keep freed blocks instead of returning them to the kernel. Each Newton
/// solve allocates and frees the same multi-megabyte buffers (CHOLMOD's factor and permuted
/// matrix, Eigen vectors); above the default thresholds glibc maps and unmaps them every
/// time, and the page faults of re-mapping cost 15-30 % of a warm 2,000-element sweep
/// (measured CPU 0.42-0.54 s -> 0.36 s). Process-wide, so set by the executable (every
/// command), not by the libraries.
void keep_freed_memory() {
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
}

}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory();
  rbc::app::install_interrupt_handlers();
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
  rbc::app::add_dynamics_command(app, action);
  rbc::app::add_infer_command(app, action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ValidationError& e) {
    // CLI11 writes "--option: TEXT: expectation"; the contract is "--option TEXT: expectation".
    std::string m = e.what();
    if (const auto colon = m.find(": "); colon != std::string::npos && m.rfind("-", 0) == 0)
      m.replace(colon, 2, " ");
    std::cerr << "rbc: error: " << m << " (see rbc --help)\n";
    return 2;
  } catch (const CLI::ParseError& e) {
    std::cerr << "rbc: error: " << e.what() << " (see rbc --help)\n";
    return 2;
  }
  // A signal during the work: exit 130 (SIGINT) / 143 (SIGTERM) once the command has unwound
  // (temporaries removed, completed outputs and manifest written); see app/interrupt.hpp.
  auto interrupted = [](const std::string& what) {
    std::cerr << "rbc: interrupted by " << rbc::app::interrupt_name() << (what.empty() ? "" : ": ")
              << what << "\n";
    return rbc::app::interrupt_exit_code();
  };
  try {
    return action ? action() : 2;
  } catch (const rbc::Cancelled&) {
    return interrupted("");
  } catch (const std::invalid_argument& e) {
    if (rbc::app::interrupt_signal() != 0) return interrupted(e.what());
    std::cerr << "rbc: error: " << e.what() << "\n";
    return 2;
  } catch (const std::runtime_error& e) {
    if (rbc::app::interrupt_signal() != 0) return interrupted(e.what());
    std::cerr << "rbc: error: " << e.what() << "\n";
    return 2;
  }
}
