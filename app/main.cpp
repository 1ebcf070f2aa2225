// SPDX-License-Identifier: GPL-3.0-or-later
// rbc: multiscale red blood cell mechanics (Hartmann 2008). One executable, one
// sub-command per job; see app/commands.hpp for the exit-code contract.
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <string>

#include "app/commands.hpp"
#include "app/interrupt.hpp"
#include "core/progress.hpp"
#include "core/version.hpp"

namespace {

/// Whether the kernel refuses to overcommit memory (vm.overcommit_memory = 2).
bool strict_overcommit() {
  std::FILE* f = std::fopen("/proc/sys/vm/overcommit_memory", "r");
  if (!f) return false;
  int mode = 0;
  const bool read = std::fscanf(f, "%d", &mode) == 1;
  std::fclose(f);
  return read && mode == 2;
}

/// glibc malloc: keep freed blocks instead of returning them to the kernel. Each Newton
/// solve allocates and frees the same multi-megabyte buffers (CHOLMOD's factor and permuted
/// matrix, Eigen vectors); above the default thresholds glibc maps and unmaps them every
/// time, and the page faults of re-mapping cost 15-30 % of a warm 2,000-element sweep
/// (measured CPU 0.42-0.54 s -> 0.36 s). Process-wide, so set by the executable (every
/// command), not by the libraries.
///
/// And the heap on transparent huge pages: the heap is grown once by kHeapReserveBytes
/// (address space only; pages are faulted in as they are first written) and that range is
/// advised MADV_HUGEPAGE, so first touches fault once per 2 MiB instead of once per 4 KiB. On
/// this project's VMs a 4 KiB fault costs about 11 us: the 5,120-element Surface Evolver row
/// (8 forces, mirror-planes, 1 thread) made 10,300 faults, a fifth of its CPU time; advised,
/// 1,500 faults and 0.48 -> 0.39 s of CPU, peak memory 59 -> 71 MiB (README, "Memory: the
/// heap on huge pages"). Advice only: where the kernel gives no huge pages nothing changes.
/// Memory beyond the reserve (and other threads' arenas) keeps 4 KiB pages.
///
/// glibc also adds the top pad to each new per-thread arena, making all of it writable at once;
/// under strict overcommit (vm.overcommit_memory = 2, found on HPC nodes) that counts against the
/// commit limit for every OpenMP/MPI thread, so the reserve (not the thresholds) is skipped there.
void keep_freed_memory() {
  constexpr int kHeapReserveBytes = 256 << 20;
  constexpr std::uintptr_t kHugePage = std::uintptr_t{2} << 20;
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  if (strict_overcommit()) return;
  mallopt(M_TOP_PAD, kHeapReserveBytes);
  // A block larger than the start-up heap's free top grows the heap by it plus the pad; freed,
  // it returns to the top, which the trim threshold keeps.
  void* grow = std::malloc(1 << 20);
  if (!grow) return;
  const std::uintptr_t start =
      (reinterpret_cast<std::uintptr_t>(grow) + kHugePage - 1) & ~(kHugePage - 1);
  std::free(grow);
  const auto end = reinterpret_cast<std::uintptr_t>(sbrk(0)) & ~(kHugePage - 1);
  if (end > start) madvise(reinterpret_cast<void*>(start), end - start, MADV_HUGEPAGE);
}

/// Idle OpenMP threads sleep instead of spinning. With OMP_WAIT_POLICY unset, libgomp's idle
/// threads spin after every parallel region and at every barrier; beside one busy process on a
/// 2-core machine they take the core the working thread needs: `rbc stretch --force 0,88
/// --vertices 2000` took 1.8x the wall time of OMP_NUM_THREADS=1 and `rbc dynamics` (continuum)
/// 2.4x, against 0.9x with OMP_WAIT_POLICY=passive. libgomp reads the variable when it is
/// loaded, before main, so an unset OMP_WAIT_POLICY is set here and the executable started
/// again in place (once: the variable is then set). A policy the user sets is kept. Process-wide,
/// so the executable's, first of all (before any thread exists).
void sleep_idle_openmp_threads(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv("/proc/self/exe", argv);
  // Not reached unless the exec failed (no /proc): run on with libgomp's default.
}

/// The error for a first argument that names no sub-command ("unknown command 'X' (expected one
/// of mesh, stretch, ...)"), empty if it names one or is an option (--help, --version).
std::string unknown_command(CLI::App& app, int argc, char** argv) {
  if (argc < 2 || argv[1][0] == '-') return "";
  const std::string given = argv[1];
  std::string names;
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    if (sub->check_name(given)) return "";
    names += (names.empty() ? "" : ", ") + sub->get_name();
  }
  return "unknown command '" + given + "' (expected one of " + names + ")";
}

}  // namespace

int main(int argc, char** argv) {
  sleep_idle_openmp_threads(argv);
  // First of all, while this is the only thread: SIGINT and SIGTERM blocked here (and so in every
  // thread created later: OpenMP, OpenBLAS, MPI) and taken by a thread of their own.
  rbc::app::install_interrupt_handlers();
  keep_freed_memory();
  CLI::App app{"rbc - multiscale red blood cell membrane mechanics (Hartmann 2008 model)"};
  app.require_subcommand(1, 1);
  app.fallthrough(false);
  app.set_version_flag("--version", rbc::version_string(), "Print the version and exit");
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
  rbc::app::add_render_command(app, action);
  if (const std::string unknown = unknown_command(app, argc, argv); !unknown.empty()) {
    std::cerr << "rbc: error: " << unknown << " (see rbc --help)\n";
    return 2;
  }
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
  } catch (const std::exception& e) {
    // A broken internal rule (std::logic_error and the like): a bug in rbc, not in the input.
    // Outputs are written atomically, so none is left half-written.
    std::cerr << "rbc: internal error: " << e.what()
              << " (a bug in rbc; please report it with the command line)\n";
    return 1;
  }
}
