// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc mc`: Monte Carlo of the spectrin network at finite temperature (single-vertex Metropolis,
// or Hamiltonian Monte Carlo of all vertices: --sampler), with
// means and blocking errors of D_A, D_T and the energy, checkpoint/restart and time series.
//
// Start: the zero-temperature equilibrium at the requested force (discrete/stretch.hpp
// solve_equilibrium, by continuation: mc_startup_forces()); its area/volume multipliers are
// then held fixed while sampling, so the chain at T -> 0 collapses onto that equilibrium and the
// reported thermal shift is <D> - D(T = 0). --start rest starts from the rest shape instead
// (same multipliers). The physics is the shared model option group (app/model_options.hpp):
// --temperature is the temperature of the WLC constants k_B T/p, and the chain samples at
// --sampling-temperature, which defaults to it (one --temperature sets both).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/interrupt.hpp"
#include "app/model_options.hpp"
#include "app/render.hpp"
#include "app/run_config.hpp"
#include "core/geometry.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"
#include "core/rest_shape.hpp"
#include "core/units.hpp"
#include "core/validation.hpp"
#include "discrete/mc_checkpoint.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/mc_workflow.hpp"
#include "discrete/stretch.hpp"

#include <mpi.h>

#include "calibrate/mpi_executor.hpp"

namespace rbc::app {

namespace {

struct McCli {
  int vertices = 500;
  double force_pN = 0.0;
  ModelCli physics;                         ///< the model option group (app/model_options.hpp)
  double sampling_temperature_K = 0.0;      ///< --sampling-temperature (K), when given
  bool sampling_temperature_given = false;  ///< else the chain samples at --temperature
  long long sweeps = 2000;
  unsigned long seed = 1;
  int streams = 2;  // fixed by default, so the chain does not depend on the thread count
  int chains = McOptions{}.chains;  ///< --chains: independent chains, pooled
  std::vector<double> forces_pN;    ///< --forces: the force list (empty: one run at --force)
  double adapt_fraction = 0.2;
  long long adapt_sweeps = -1;  // -1: adapt_fraction x sweeps
  int sample_every = 1;
  double penalty_scale = McRunSetup{}.penalty_scale;
  std::string checkpoint, resume, out;
  McStart start = McStart::equilibrium;
  McAlgorithm algorithm = McAlgorithm::metropolis;  ///< --sampler
  HmcOptions hmc;                                   ///< --hmc-step, --hmc-trajectory-time
  long long checkpoint_every = 100;
  long long snapshot_every = 0;
  bool json = false, quiet = false, verbose = false, overwrite = false;
  bool picture = true;  ///< --out: cells.png of the first and the last snapshot (--no-picture)
  /// What produced the run: command, resolved configuration, provenance (app/run_config.hpp);
  /// run.json starts from it, mc_summary.json and --json include it.
  nlohmann::json record;
  /// The temperature the chain samples at (K): --sampling-temperature, else --temperature.
  double sampling_temperature() const {
    return sampling_temperature_given ? sampling_temperature_K : physics.temperature_K;
  }
};

/// Largest --sweeps accepted: 1e12 sweeps (about 30 years at 1,000 sweeps/s).
constexpr long long kMaxSweeps = 1000000000000LL;

/// Library quantities -> this command's options (errors name the option the user typed).
OptionNames mc_option_names() {
  OptionNames names = model_option_names();
  names.insert({
      {"force (discrete model)", "--force"},
      {"sampling temperature", "--sampling-temperature"},
      {"RNG streams", "--streams"},
      {"chains", "--chains"},
      {"penalty scale", "--penalty-scale"},
      {"sample interval (sweeps)", "--sample-every"},
      {"adaptive fraction", "--adapt-fraction"},
      {"adaptive sweeps", "--adapt-sweeps (or --adapt-fraction x --sweeps)"},
      {"HMC leapfrog step", "--hmc-step"},
      {"HMC trajectory time", "--hmc-trajectory-time"},
      {"HMC mass shift fraction", "--hmc-mass-shift"},
      {"HMC sampling temperature", "--sampling-temperature"},
  });
  return names;
}

/// Whether DIR holds the outputs of an `rbc mc` run (so a resumed run may write into it): its
/// series or summary, or its run.json (all a run killed before its first series leaves).
bool holds_mc_run(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(fs::path(dir) / "mc_summary.json", ec) ||
      fs::exists(fs::path(dir) / "mc_series.csv", ec))
    return true;
  std::ifstream in(fs::path(dir) / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  return j.is_object() && j.value("command", "") == "mc";
}

/// How far a run got, for the manifest of a run that fails: whether run.json says "running"
/// and the sweeps done so far.
struct McProgress {
  bool running = false;
  long long sweeps_done = 0;
};

/// What the written files record of the run (app/run_config.hpp): CSV comment lines, HDF5
/// text attributes.
OutputRecord output_record(const McCli& o) {
  if (!o.record.is_object()) return {};
  return {record_comment_lines(o.record), record_attributes(o.record)};
}

/// DIR/run.json of `mc --out`: whether the outputs are those of a finished run ("complete"),
/// the status (running | interrupted | finished), the reason, the sweeps done and requested
/// and the checkpoint written on the way out. Rewritten atomically at each change.
/// The run record (command, config, provenance: app/run_config.hpp) comes first, so
/// `--config DIR/run.json` repeats the run.
void write_mc_manifest(const McCli& o, bool complete, const std::string& status,
                       const std::string& reason, long long sweeps_done,
                       const std::string& checkpoint, const nlohmann::json& extra = {}) {
  const std::string& dir = o.out;
  const long long sweeps = o.sweeps;
  if (dir.empty()) return;
  nlohmann::json j = o.record.is_object() ? o.record : nlohmann::json::object();
  j.update({{"command", "mc"},
            {"complete", complete},
            {"status", status},
            {"sweeps_done", sweeps_done},
            {"sweeps_requested", sweeps}});
  if (!reason.empty()) j["reason"] = reason;
  if (!checkpoint.empty()) j["checkpoint"] = checkpoint;
  if (complete) {
    j["files"] = {"mc_series.csv", "mc_series.h5", "mc_summary.json"};
  }
  if (extra.is_object()) j.update(extra);
  write_text_atomic(dir + "/run.json", j.dump(2) + "\n");
}

/// OUT/cells.png: the first and the last snapshot in OUT (app/render.hpp); returns why there is
/// no picture ("" when drawn).
std::string draw_mc_picture(const McCli& o, const Network& net, const McRunSetup& su) {
  std::vector<std::string> snapshots;
  for (const auto& entry : std::filesystem::directory_iterator(o.out)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("mc_snapshot_", 0) == 0 && entry.path().extension() == ".xdmf")
      snapshots.push_back(entry.path().string());
  }
  if (snapshots.empty()) return "no snapshot was written";
  std::sort(snapshots.begin(), snapshots.end());  // zero-padded sweep numbers: sweep order
  RenderRequest r;
  r.files = {snapshots.front()};
  if (snapshots.size() > 1) r.files.push_back(snapshots.back());
  std::ostringstream title;
  title << "Monte Carlo, " << net.topo.num_vertices << " vertices, F = " << su.force_pN
        << " pN, T = " << su.sampler.temperature_K << " K";
  r.title = title.str();
  r.out_png = o.out + "/cells.png";
  if (o.record.is_object()) r.metadata = record_png_text(o.record);
  return draw_cells(r);
}

/// Which chain-defining options were given on the command line (checked against a resumed
/// checkpoint, which otherwise supplies them).
struct GivenOptions {
  bool force = false, temperature = false, seed = false, penalty_scale = false, vertices = false,
       bending = false, adapt_fraction = false, sampler = false, chains = false,
       area_volume = false;
  std::string hmc_option;  ///< the first --hmc-* option given ("" when none)
};

/// The run's setup from the command line (multipliers and reference filled in later),
/// validated: every bad number is refused here, before any work.
McRunSetup to_setup(const McCli& o) {
  require_finite_in_range("adaptive fraction", "", o.adapt_fraction, 0.0, 1.0, Ends::closed_open);
  McRunSetup setup;
  setup.force_pN = o.force_pN;
  setup.sampler.temperature_K = o.sampling_temperature();
  setup.sampler.seed = o.seed;
  setup.sampler.algorithm = o.algorithm;
  setup.sampler.hmc = o.hmc;
  setup.sampler.streams = o.streams > 0 ? o.streams : omp_get_max_threads();
  setup.sampler.chains = o.chains;
  setup.sampler.adapt_sweeps = static_cast<int>(std::min<double>(
      std::llround(o.adapt_fraction * double(o.sweeps)), std::numeric_limits<int>::max()));
  setup.sample_every = o.sample_every;
  setup.penalty_scale = o.penalty_scale;
  setup.validate();
  return setup;
}

/// A new chain: its setup (to_setup with `seed` and the adaptive phase of --adapt-sweeps or
/// --adapt-fraction), its schedule, and its start, the zero-temperature equilibrium by
/// continuation (which also fills the setup's multipliers and reference), solved on one thread
/// for a bit-reproducible start state.
struct NewMcChain {
  McRunSetup setup;
  McSchedule schedule;
  McZeroTemperatureStart start;
};

NewMcChain new_mc_chain(const Network& net, const McCli& o, unsigned long seed,
                        const CancelCheck& cancel, const ProgressSink& progress) {
  NewMcChain c;
  c.setup = to_setup(o);
  c.setup.sampler.seed = seed;
  if (o.adapt_sweeps >= 0) c.setup.sampler.adapt_sweeps = static_cast<int>(o.adapt_sweeps);
  c.setup.cancel = cancel;
  c.schedule.planned_sweeps = o.sweeps;
  c.schedule.adapt_fraction = o.adapt_sweeps >= 0 ? -1.0 : o.adapt_fraction;
  McStartOptions so;
  so.start = o.start;
  so.cancel = cancel;
  SerialOpenMpScope serial;
  c.start = mc_zero_temperature_start(net, c.setup, so, progress);
  return c;
}

/// Sweeps per block of the chains (McRun::advance_blocks): a divisor of the checkpoint and
/// snapshot intervals (checkpoints and snapshots fall on block ends), at most ~20,000 vertex
/// moves (Metropolis) or 4 trajectories (HMC) per chain, so progress and checkpoints keep up.
/// The chains never depend on it.
long long mc_block_sweeps(const McCli& o, const McRun& run) {
  long long block = o.checkpoint_every;
  if (o.snapshot_every > 0) block = std::gcd(block, o.snapshot_every);
  const long long cap =
      run.sampler().algorithm() == McAlgorithm::hmc
          ? 4
          : std::max(1LL, 20000LL / std::max(1LL, (long long)run.sampler().mobile_vertices()));
  return std::gcd(block, cap);
}

/// The progress line of a block: the sweep and, per chain, acceptance and D_A of its last sample.
std::string mc_progress_line(const McRun& r, long long sweeps) {
  std::ostringstream m;
  m << "sweep " << r.sweeps_done() << "/" << sweeps;
  for (int c = 0; c < r.chain_count(); ++c) {
    m << (c == 0 ? ": " : "; ") << "chain " << c << " step " << r.chain(c).step_um()
      << (r.chain(c).algorithm() == McAlgorithm::hmc ? "" : " um");
    if (!r.series(c).empty())
      m << ", acceptance " << r.series(c).back().acceptance << ", D_A "
        << r.series(c).back().axial_um << " um";
  }
  return m.str();
}

int run_mc(const McCli& o, const GivenOptions& given, McProgress& progress_made) {
  if (o.adapt_sweeps < -1 || o.adapt_sweeps > o.sweeps)
    throw std::invalid_argument(
        "--adapt-sweeps " + std::to_string(o.adapt_sweeps) +
        ": expected an integer in [0, --sweeps = " + std::to_string(o.sweeps) + "]");
  {
    McRunSetup up_front = to_setup(o);  // every number up front (on --resume too)
    if (o.adapt_sweeps >= 0 && o.resume.empty()) {
      up_front.sampler.adapt_sweeps = static_cast<int>(o.adapt_sweeps);
      up_front.validate();  // e.g. the thermal HMC mass reference's adaptive sweeps
    }
  }
  const NetworkParameters model = to_network_parameters(o.physics);  // the physics, validated
  if (std::error_code ec; !o.resume.empty() && !std::filesystem::is_regular_file(o.resume, ec))
    throw std::invalid_argument("--resume " + o.resume + ": no such checkpoint file");
  if (!o.checkpoint.empty()) check_output_file(o.checkpoint, "--checkpoint");
  if (!o.out.empty())
    prepare_output_directory(o.out, o.overwrite, !o.resume.empty() && holds_mc_run(o.out));
  const ProgressSink progress = stderr_progress(o.quiet, o.verbose);
  const CancelCheck cancel = interrupt_check();

  RestShapeOptions ro;
  ro.target_vertices = o.vertices;
  NetworkParameters params = model;
  McResumeRequest request;  // the chain-defining options given (checked against a checkpoint)
  if (given.force) request.force_pN = o.force_pN;
  if (given.temperature) request.temperature_K = o.sampling_temperature();
  if (given.seed) request.seed = o.seed;
  if (given.penalty_scale) request.penalty_scale = o.penalty_scale;
  if (given.bending) request.bending_model = o.physics.bending;
  if (given.adapt_fraction) request.adapt_fraction = o.adapt_fraction;
  if (given.sampler) request.algorithm = o.algorithm;
  if (given.chains) request.chains = o.chains;
  if (given.area_volume) request.area_volume = o.hmc.area_volume;
  if (o.adapt_sweeps >= 0) request.adapt_sweeps = o.adapt_sweeps;
  request.total_sweeps = o.sweeps;
  if (!o.resume.empty()) {
    // The network comes from the checkpoint unless given; a different one given is an error
    // (caught by the fingerprint for the mesh, named here for the bending model).
    const McCheckpointNetwork cn = peek_mc_checkpoint_network(o.resume);
    if (cn.algorithm != McAlgorithm::hmc && !given.hmc_option.empty())
      throw std::invalid_argument(given.hmc_option +
                                  ": an option of --sampler hmc, but the checkpoint '" + o.resume +
                                  "' holds a chain of --sampler " + to_string(cn.algorithm));
    if (!given.vertices) ro.target_vertices = cn.vertices;
    check_mc_resume_network(cn, request, o.resume);
    params.bending_model = cn.bending_model;
  }
  const Network net = [&] {
    SerialOpenMpScope serial;  // the rest shape must be identical on resume (network fingerprint)
    return build_network(make_rest_shape(ro), params);
  }();
  report(progress, "network: " + std::to_string(net.topo.num_vertices) + " vertices");

  std::unique_ptr<McRun> run;
  McSchedule schedule;
  std::string resume_note;  // what differs from a straight run, when extending a checkpoint
  if (!o.resume.empty()) {
    McCheckpoint cp = read_mc_checkpoint(o.resume, net);
    schedule = cp.schedule;
    resume_note = check_mc_resume(cp, request, o.resume);
    if (!resume_note.empty()) report(progress, "note: " + resume_note);
    report(progress, "resuming at sweep " + std::to_string(cp.chain.sweep) + " from " + o.resume);
    cp.setup.cancel = cancel;
    run = std::make_unique<McRun>(net, cp.setup, cp.chains, cp.chain_series);
  } else {
    const NewMcChain c = new_mc_chain(net, o, o.seed, cancel, progress);
    schedule = c.schedule;
    const McZeroTemperatureStart& z = c.start;
    if (!z.converged) {
      const StretchPoint& eq = z.equilibrium;
      std::cerr << "rbc: error: zero-temperature equilibrium at " + format_number(eq.force_pN) +
                       " pN did not converge: " + to_string(eq.status) + ", residual " +
                       format_scientific(eq.residual_pN) + " pN\n";
      return 1;
    }
    run = std::make_unique<McRun>(net, c.setup, z.start);
  }

  const long long first_sweep = run->sweeps_done();
  auto write_checkpoint = [&](const McRun& r) {
    if (!o.checkpoint.empty())
      write_mc_checkpoint(o.checkpoint, net, McCheckpoint::of(r, schedule));
  };
  progress_made.sweeps_done = first_sweep;
  progress_made.running = !o.out.empty();
  // The thread decision (discrete/mc_sampler.hpp mc_thread_decision), in every manifest.
  const nlohmann::json threads = {{"threads", to_json(run->thread_decision())},
                                  {"chains", run->chain_count()}};
  write_mc_manifest(o, false, "running", "the run has not finished", first_sweep, "", threads);
  if (!o.out.empty()) write_mc_snapshot(o.out, net, *run, output_record(o));
  const auto t0 = std::chrono::steady_clock::now();
  auto last_report = t0;
  try {
    run->advance_blocks(o.sweeps, mc_block_sweeps(o, *run), [&](const McRun& r) {
      const long long s = r.sweeps_done();
      progress_made.sweeps_done = s;
      if (s % o.checkpoint_every == 0) write_checkpoint(r);
      if (!o.out.empty() && o.snapshot_every > 0 && s % o.snapshot_every == 0)
        write_mc_snapshot(o.out, net, r, output_record(o));
      const auto now = std::chrono::steady_clock::now();
      if (std::chrono::duration<double>(now - last_report).count() > 5.0) {
        last_report = now;
        report(progress, mc_progress_line(r, o.sweeps));
      }
      return true;
    });
  } catch (const Cancelled&) {
    // The chain stands at its last completed sweep: a final checkpoint and the series so far
    // are written on the way out (complete files); the manifest says the run is incomplete.
    const long long s = run->sweeps_done();
    write_checkpoint(*run);
    if (!o.out.empty()) write_mc_series(o.out, *run, output_record(o));
    write_mc_manifest(o, false, "interrupted",
                      "interrupted by " + interrupt_name() + " after sweep " + std::to_string(s) +
                          " of " + std::to_string(o.sweeps) +
                          (o.checkpoint.empty() ? "" : "; resume with --resume " + o.checkpoint),
                      s, o.checkpoint, threads);
    throw;
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_checkpoint(*run);
  if (!o.out.empty()) {
    write_mc_series(o.out, *run, output_record(o));
    if (o.snapshot_every == 0 || run->sweeps_done() % o.snapshot_every != 0)
      write_mc_snapshot(o.out, net, *run, output_record(o));
  }

  const long long done = run->sweeps_done() - first_sweep;
  const long long mobile = run->sampler().mobile_vertices();
  const double sweeps_per_s = wall > 0 ? double(done) / wall : 0.0;
  const McRunSetup& su = run->setup();
  // The run record first (command, config, provenance), then the run and its statistics.
  nlohmann::json j = o.record.is_object() ? o.record : nlohmann::json::object();
  j.update(mc_run_json(net, *run));
  // Sweeps per second of one chain (every chain ran `done` sweeps in `wall`).
  j.update({{"sweeps_this_run", done},
            {"wall_s", wall},
            {"sweeps_per_s", sweeps_per_s},
            {"moves_per_s", sweeps_per_s * double(mobile)}});
  bool have_stats = true;
  McSummary s;
  try {
    s = run->summarise();
  } catch (const std::invalid_argument& e) {
    have_stats = false;
    j["statistics"] = e.what();
  }
  if (have_stats) j.update(to_json(s, su));
  if (!resume_note.empty()) j["resume_note"] = resume_note;
  if (!o.out.empty()) write_text_atomic(o.out + "/mc_summary.json", j.dump(2) + "\n");
  nlohmann::json picture = nlohmann::json::object();
  if (!o.out.empty() && o.picture) {
    const std::string why_not = draw_mc_picture(o, net, su);
    picture[why_not.empty() ? "picture" : "picture_not_drawn"] =
        why_not.empty() ? "cells.png" : why_not;
    if (!why_not.empty() && !o.quiet) std::cerr << "rbc: note: no cells.png: " << why_not << "\n";
  }
  picture.update(threads);
  write_mc_manifest(o, true, "finished", "", run->sweeps_done(), o.checkpoint, picture);
  if (o.json) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << std::setprecision(6) << "Monte Carlo (" << to_string(su.sampler.algorithm)
            << "): N = " << net.topo.num_vertices << ", F = " << su.force_pN
            << " pN, T = " << su.sampler.temperature_K << " K, " << run->chain_count()
            << " chains of " << run->sweeps_done() << " sweeps (" << su.sampler.adapt_sweeps
            << " adaptive), " << su.sampler.streams << " streams, " << run->sampler().colour_count()
            << " colours\n"
            << "speed: " << sweeps_per_s << " sweeps/s, " << sweeps_per_s * double(mobile)
            << " moves/s per chain; threads " << run->thread_decision().reason << "\n";
  if (!have_stats) {
    std::cout << "statistics: " << j["statistics"].get<std::string>() << "\n";
    return 0;
  }
  auto line = [](const char* name, const BlockingResult& b, const McConvergence& c,
                 const char* unit) {
    // To the error's significance (two digits); std and inefficiency g to two and three.
    std::ostringstream rest;
    rest << std::setprecision(2) << std::sqrt(b.variance) << ", g " << std::setprecision(3)
         << b.inefficiency;
    std::cout << "  " << std::left << std::setw(8) << name << std::right
              << format_with_error(b.mean, b.error) << " " << unit << "  (std " << rest.str()
              << ", R-hat " << std::setprecision(4) << c.rhat
              << (b.converged ? "" : ", error not converged: run longer")
              << (c.converged ? "" : ", chains disagree: run longer") << ")\n";
  };
  std::cout << "production samples " << s.samples << " (" << s.chains
            << " chains pooled; R-hat: rank-normalised split-R-hat, converged below "
            << kMcRhatThreshold << (s.converged ? "" : ", NOT converged")
            << "), transient discarded " << s.discarded << " per chain"
            << ", acceptance " << s.acceptance << ", step " << run->sampler().step_um()
            << (run->sampler().algorithm() == McAlgorithm::hmc ? " (leapfrog, dimensionless)\n"
                                                               : " um\n");
  line("D_A", s.axial, s.axial_check, "um");
  line("D_T", s.transverse, s.transverse_check, "um");
  line("energy", s.energy, s.energy_check, "pN um");
  line("area", s.area, s.area_check, "um^2");
  line("volume", s.volume, s.volume_check, "um^3");
  std::cout << "thermal shift vs T = 0: D_A "
            << format_with_error(s.axial.mean - su.reference_axial_um, s.axial.error) << " um, D_T "
            << format_with_error(s.transverse.mean - su.reference_transverse_um, s.transverse.error)
            << " um\n"
            << "largest drift |A - A0|/A0 = " << format_scientific(s.max_area_drift)
            << ", |V - V0|/V0 = " << format_scientific(s.max_volume_drift) << "\n";
  return 0;
}

/// Largest --forces list.
constexpr std::size_t kMaxForces = 64;

/// The seed of force k of a --forces list: --seed for the first, else mc_chain_seed of --seed at
/// index kMaxMcChains + k (a stream of indices no chain of the first force uses); chain c of
/// force k then has mc_chain_seed(force seed, c). Results depend on (seed, force index, chain)
/// only, never on the MPI rank that ran the force.
unsigned long mc_force_seed(unsigned long seed, std::size_t k) {
  return k == 0 ? seed : mc_chain_seed(seed, kMaxMcChains + static_cast<int>(k));
}

/// What a force of the list gives the thermal curve (the fields every rank fills for its
/// forces; the others stay 0, so a sum over the ranks assembles the curve exactly).
enum ForceField {
  kForce,
  kRefAxial,
  kRefTransverse,
  kAxial,
  kAxialError,
  kTransverse,
  kTransverseError,
  kRhatAxial,
  kRhatTransverse,
  kConverged,
  kHaveStats,
  kForceFields
};

/// DIR/checkpoints of a force list run with --out DIR: force_KK.h5 per force (the checkpoint
/// format of one force, discrete/mc_checkpoint.hpp) and force_list.json (the options that define
/// the curve, compared by --resume DIR).
std::string force_checkpoint_dir(const std::string& out) {
  return out + "/checkpoints";
}
constexpr const char* kForceListFile = "force_list.json";

/// "force_KK": force k's output directory under DIR and its checkpoint's name (force_KK.h5).
std::string force_name(std::size_t k) {
  std::ostringstream name;
  name << "force_" << std::setw(2) << std::setfill('0') << k;
  return name.str();
}

std::string force_checkpoint_path(const std::string& out, std::size_t k) {
  return force_checkpoint_dir(out) + "/" + force_name(k) + ".h5";
}

/// The options that define a force list's chains and curve, by option name, resolved (the
/// adaptive sweeps as an absolute count, the streams as the run uses them): stored in
/// DIR/checkpoints/force_list.json and compared by --resume DIR, so the forces run on resume
/// (fresh or continued) are those of the run it continues; compared in this order, so an error
/// names --temperature (which sets both) before --sampling-temperature. --checkpoint-every,
/// --snapshot-every and the output options do not change a chain and are not in it.
nlohmann::ordered_json force_list_definition(const McCli& o) {
  const McRunSetup su = to_setup(o);
  const ModelCli& m = o.physics;
  nlohmann::ordered_json j = {
      {"--forces", o.forces_pN},
      {"--sweeps", o.sweeps},
      {"--seed", std::to_string(o.seed)},
      {"--chains", o.chains},
      {"--sampler", to_string(o.algorithm)},
      {"--temperature", m.temperature_K},
      {"--sampling-temperature", o.sampling_temperature()},
      {"--streams", su.sampler.streams},
      {"--adapt-sweeps", o.adapt_sweeps >= 0 ? o.adapt_sweeps : su.sampler.adapt_sweeps},
      {"--sample-every", o.sample_every},
      {"--penalty-scale", o.penalty_scale},
      {"--start", to_string(o.start)},
      {"--vertices", o.vertices},
      {"--lbar", m.lbar_nm},
      {"--lmax", m.lmax_nm},
      {"--persistence", m.persistence_nm},
      {"--kappa", m.kappa_J},
      {"--h0", m.h0_per_um},
      {"--q", m.q},
      {"--eta", m.eta},
      {"--contact", static_cast<int>(m.contact)},
      {"--contact-fraction", m.contact_fraction},
      {"--bending", to_string(m.bending)},
      {"--dihedral-mapping", static_cast<int>(m.dihedral_mapping)}};
  if (o.algorithm == McAlgorithm::hmc)
    j.update({{"--hmc-step", o.hmc.step},
              {"--hmc-trajectory-time", o.hmc.trajectory_time},
              {"--hmc-mass", o.hmc.projected_mass ? "projected" : "exact"},
              {"--hmc-mass-shift", o.hmc.mass_shift_fraction},
              {"--hmc-mass-reference", to_string(o.hmc.mass_reference)},
              {"--hmc-area-volume", to_string(o.hmc.area_volume)}});
  return j;
}

/// --resume DIR of a force list: DIR holds a force list's checkpoints and this run's options
/// define the same curve (std::invalid_argument naming the first option that differs, with both
/// values). Reads files only.
void check_force_list_resume(const McCli& o) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(o.resume, ec))
    throw std::invalid_argument("--resume " + o.resume +
                                ": no such directory (expected the --out directory of an "
                                "rbc mc --forces run)");
  if (!o.out.empty() && !(fs::equivalent(o.out, o.resume, ec) && !ec))
    throw std::invalid_argument("--out " + o.out +
                                ": a resumed force list writes into its own directory (--resume " +
                                o.resume + "); leave --out out or give the same directory");
  const fs::path list = fs::path(force_checkpoint_dir(o.resume)) / kForceListFile;
  std::ifstream in(list);
  const nlohmann::ordered_json stored = nlohmann::ordered_json::parse(in, nullptr, false);
  if (!in.is_open() || !stored.is_object())
    throw std::invalid_argument("--resume " + o.resume + ": no readable checkpoints/" +
                                kForceListFile +
                                " in it (rbc mc --forces ... --out DIR writes one at its start)");
  const nlohmann::ordered_json wanted = force_list_definition(o);
  for (const nlohmann::ordered_json* side : {&wanted, &stored})
    for (const auto& [option, value] : side->items()) {
      const nlohmann::ordered_json mine = wanted.value(option, nlohmann::ordered_json()),
                                   theirs = stored.value(option, nlohmann::ordered_json());
      if (mine != theirs)
        throw std::invalid_argument(
            "--resume " + o.resume + ": " + option + " differs from the run it continues (" +
            (theirs.is_null() ? std::string("not given") : theirs.dump()) + " there, " +
            (mine.is_null() ? std::string("not given") : mine.dump()) +
            " here; expected the options of that run)");
    }
}

/// Removes what a run killed mid-write leaves in DIR/checkpoints: the temporaries of checkpoint
/// writes (".force_KK.h5.partial-PID", core/io.hpp TempFile), none of them a complete checkpoint.
void remove_checkpoint_temporaries(const std::string& out) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(force_checkpoint_dir(out), ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(".force_", 0) == 0 && name.find(".partial-") != std::string::npos)
      fs::remove(e.path(), ec);
  }
}

/// What force k's checkpoint must hold: the force, its seed and every chain-defining option of
/// the list (check_mc_resume).
McResumeRequest force_resume_request(const McCli& o, std::size_t k) {
  McResumeRequest r;
  r.force_pN = o.forces_pN[k];
  r.temperature_K = o.sampling_temperature();
  r.seed = mc_force_seed(o.seed, k);
  r.penalty_scale = o.penalty_scale;
  r.bending_model = o.physics.bending;
  r.algorithm = o.algorithm;
  r.chains = o.chains;
  r.adapt_sweeps = o.adapt_sweeps >= 0 ? o.adapt_sweeps : to_setup(o).sampler.adapt_sweeps;
  r.total_sweeps = o.sweeps;
  return r;
}

/// Reads and checks every force checkpoint in DIR/checkpoints against the network and the
/// options (read_mc_checkpoint, check_mc_resume): a corrupt or foreign one is refused before
/// any sampling.
void check_force_checkpoints(const McCli& o, const Network& net) {
  std::error_code ec;
  for (std::size_t k = 0; k < o.forces_pN.size(); ++k) {
    const std::string path = force_checkpoint_path(o.out, k);
    if (!std::filesystem::is_regular_file(path, ec)) continue;
    check_mc_resume(read_mc_checkpoint(path, net), force_resume_request(o, k), path);
  }
}

/// One force of the list with its chains: start, sampling, and DIR/force_KK/ outputs. With
/// --out, the chains are checkpointed in DIR/checkpoints/force_KK.h5 at sweep 0, every
/// --checkpoint-every sweeps, when interrupted and at the end (a checkpoint at --sweeps marks
/// the force finished); on --resume a force with a checkpoint continues from it (a finished one
/// runs no sweep), a force without one starts afresh.
std::vector<double> run_one_force(const McCli& o, const Network& net, std::size_t k,
                                  const CancelCheck& cancel, const ProgressSink& progress) {
  McCli one = o;
  one.force_pN = o.forces_pN[k];
  const std::string label =
      "force " + std::to_string(k) + " (" + format_number(one.force_pN) + " pN)";
  const std::string checkpoint = o.out.empty() ? "" : force_checkpoint_path(o.out, k);
  std::unique_ptr<McRun> run;
  McSchedule schedule;
  std::error_code ec;
  const bool resumed = !o.resume.empty() && std::filesystem::is_regular_file(checkpoint, ec);
  if (resumed) {
    McCheckpoint cp = read_mc_checkpoint(checkpoint, net);
    schedule = cp.schedule;
    cp.setup.cancel = cancel;
    run = std::make_unique<McRun>(net, cp.setup, cp.chains, cp.chain_series);
    report(progress, run->sweeps_done() >= o.sweeps
                         ? label + ": finished, from " + checkpoint
                         : label + ": resuming at sweep " + std::to_string(run->sweeps_done()) +
                               " from " + checkpoint);
  } else {
    const NewMcChain c = new_mc_chain(net, one, mc_force_seed(o.seed, k), cancel, {});
    schedule = c.schedule;
    const McZeroTemperatureStart& z = c.start;
    if (!z.converged)
      throw std::runtime_error("zero-temperature equilibrium at " +
                               format_number(z.equilibrium.force_pN) +
                               " pN did not converge: " + to_string(z.equilibrium.status));
    run = std::make_unique<McRun>(net, c.setup, z.start);
  }
  auto write_checkpoint = [&](const McRun& r, const std::string& why = "") {
    if (checkpoint.empty()) return;
    write_mc_checkpoint(checkpoint, net, McCheckpoint::of(r, schedule));
    report_detail(progress,
                  label + ": checkpoint at sweep " + std::to_string(r.sweeps_done()) + why);
  };
  const bool finished_before = run->sweeps_done() >= o.sweeps;
  if (!resumed) write_checkpoint(*run);  // the start, so a resume never repeats its solves
  try {
    run->advance_blocks(o.sweeps, mc_block_sweeps(o, *run), [&](const McRun& r) {
      if (r.sweeps_done() % o.checkpoint_every == 0 && r.sweeps_done() < o.sweeps)
        write_checkpoint(r);
      return true;
    });
  } catch (const Cancelled&) {
    write_checkpoint(*run, " (interrupted)");  // every chain at its last completed sweep
    throw;
  }
  if (!finished_before) write_checkpoint(*run);  // at --sweeps: the force is finished
  const McRunSetup& setup = run->setup();
  std::vector<double> f(kForceFields, 0.0);
  f[kForce] = one.force_pN;
  f[kRefAxial] = setup.reference_axial_um;
  f[kRefTransverse] = setup.reference_transverse_um;
  nlohmann::json j = o.record.is_object() ? o.record : nlohmann::json::object();
  j.update(mc_run_json(net, *run));
  j["force_index"] = k;
  try {
    const McSummary s = run->summarise();
    j.update(to_json(s, setup));
    f[kAxial] = s.axial.mean;
    f[kAxialError] = s.axial.error;
    f[kTransverse] = s.transverse.mean;
    f[kTransverseError] = s.transverse.error;
    f[kRhatAxial] = s.axial_check.rhat;
    f[kRhatTransverse] = s.transverse_check.rhat;
    f[kConverged] = s.converged && s.axial.converged && s.transverse.converged ? 1.0 : 0.0;
    f[kHaveStats] = 1.0;
  } catch (const std::invalid_argument& e) {
    j["statistics"] = e.what();
  }
  if (!o.out.empty()) {
    const std::string dir = o.out + "/" + force_name(k);
    std::filesystem::create_directories(dir);
    write_mc_series(dir, *run, output_record(o));
    write_text_atomic(dir + "/mc_summary.json", j.dump(2) + "\n");
  }
  report(progress, "force " + format_number(one.force_pN) + " pN done");
  return f;
}

/// `rbc mc --forces F1,F2,...`: each force with its chains, the forces spread over the MPI
/// ranks when started by mpirun (force k on rank k mod ranks), and the thermal curve. The
/// curve is assembled by a sum over the ranks (MPI_Allreduce) in which every entry has exactly
/// one nonzero term, so it is exact and independent of the rank count. A small loop here, not
/// calibrate/mpi_executor's pool: that executor serves TMCMC chains (a prior box and a
/// likelihood), not Monte Carlo runs; its MpiSession is reused. With --out DIR every force is
/// checkpointed (run_one_force) and --resume DIR continues the list; a force's checkpoint
/// depends on its seed and options only, so the curve of a resumed list is that of a straight
/// run on any number of ranks and threads.
int run_mc_forces(const McCli& given_cli, const GivenOptions& given) {
  McCli o = given_cli;
  if (given.force)
    throw std::invalid_argument("--forces: give the forces as --forces F1,F2,... without --force");
  if (!o.checkpoint.empty())
    throw std::invalid_argument("--checkpoint " + o.checkpoint +
                                ": a force list keeps one checkpoint per force in DIR/checkpoints/ "
                                "of --out DIR (expected --out DIR, and --resume DIR to continue)");
  if (o.forces_pN.size() > kMaxForces)
    throw std::invalid_argument("--forces: at most " + std::to_string(kMaxForces) +
                                " forces, got " + std::to_string(o.forces_pN.size()));
  if (o.adapt_sweeps < -1 || o.adapt_sweeps > o.sweeps)
    throw std::invalid_argument(
        "--adapt-sweeps " + std::to_string(o.adapt_sweeps) +
        ": expected an integer in [0, --sweeps = " + std::to_string(o.sweeps) + "]");
  for (double f : o.forces_pN) {
    McCli one = o;
    one.force_pN = f;
    try {
      to_setup(one);  // every force validated before any work
    } catch (const std::invalid_argument&) {
      throw std::invalid_argument("--forces " + format_number(f) + ": expected forces in [0, " +
                                  format_number(kMaxDiscreteForce_pN) + "] pN");
    }
  }
  const NetworkParameters model = to_network_parameters(o.physics);
  if (!o.resume.empty()) {
    check_force_list_resume(o);  // before any work: the same curve, or exit 2
    o.out = o.resume;
  } else if (std::error_code ec;
             !o.out.empty() && !o.overwrite &&
             std::filesystem::exists(
                 std::filesystem::path(force_checkpoint_dir(o.out)) / kForceListFile, ec))
    throw std::invalid_argument("--out " + o.out +
                                ": holds the checkpoints of a force list; continue it with "
                                "--resume " +
                                o.out + ", or pass --force-overwrite to start afresh");
  const bool mpi = launched_by_mpirun();
  std::unique_ptr<MpiSession> session;
  if (mpi) session = std::make_unique<MpiSession>();
  const int rank = session ? session->rank() : 0, ranks = session ? session->size() : 1;
  if (!o.out.empty() && rank == 0) {
    prepare_output_directory(o.out, o.overwrite, !o.resume.empty());
    if (o.resume.empty()) {
      // A fresh list: no checkpoint of another run may stay (--force-overwrite).
      std::filesystem::remove_all(force_checkpoint_dir(o.out));
      std::filesystem::create_directories(force_checkpoint_dir(o.out));
      write_text_atomic(force_checkpoint_dir(o.out) + "/" + kForceListFile,
                        force_list_definition(o).dump(2) + "\n");
    } else {
      remove_checkpoint_temporaries(o.out);
    }
  }
  if (session) MPI_Barrier(MPI_COMM_WORLD);  // the directory exists before any rank writes
  const ProgressSink progress = stderr_progress(o.quiet || rank != 0, o.verbose);
  const CancelCheck cancel = interrupt_check();
  RestShapeOptions ro;
  ro.target_vertices = o.vertices;
  const Network net = [&] {
    SerialOpenMpScope serial;
    return build_network(make_rest_shape(ro), model);
  }();
  if (!o.resume.empty()) {
    try {
      check_force_checkpoints(o, net);
    } catch (const std::exception&) {
      if (rank == 0) throw;  // one line, from rank 0; every rank finds the same and stops
      return 2;
    }
  }
  std::vector<double> mine(o.forces_pN.size() * kForceFields, 0.0), all(mine.size(), 0.0);
  try {
    for (std::size_t k = 0; k < o.forces_pN.size(); ++k)
      if (static_cast<int>(k % std::size_t(ranks)) == rank) {
        const std::vector<double> f = run_one_force(o, net, k, cancel, progress);
        std::copy(f.begin(), f.end(), mine.begin() + std::ptrdiff_t(k * kForceFields));
      }
  } catch (const Cancelled&) {
    // Every force of this rank stands at a complete checkpoint (run_one_force): one line on
    // how to continue.
    const std::string how = o.out.empty()
                                ? std::string("a force list without --out keeps no checkpoints")
                                : "checkpoints of the forces in " + force_checkpoint_dir(o.out) +
                                      "; continue with the same options and --resume " + o.out;
    if (!session) throw std::runtime_error(how);  // main(): "rbc: interrupted by SIG...: how"
    std::cerr << "rbc: interrupted by " << interrupt_name() << ": " << how << "\n";
    session->abort(interrupt_exit_code());
  } catch (const std::exception& e) {
    if (!session) throw;
    std::cerr << "rbc: error: MPI rank " << rank << ": " << e.what() << "\n";
    session->abort(1);
  }
  if (session)
    MPI_Allreduce(mine.data(), all.data(), static_cast<int>(mine.size()), MPI_DOUBLE, MPI_SUM,
                  MPI_COMM_WORLD);
  else
    all = mine;
  if (rank != 0) return 0;
  CsvTable t;
  t.comments = {"rbc mc --forces: thermal curve, pooled over " + std::to_string(o.chains) +
                " chains per force; shift = D(T) - D(0 K), its error the pooled error of D(T)"};
  const OutputRecord rec = output_record(o);
  t.comments.insert(t.comments.end(), rec.comment_lines.begin(), rec.comment_lines.end());
  t.header = {"force_pN",
              "axial_um",
              "axial_error_um",
              "transverse_um",
              "transverse_error_um",
              "reference_axial_um",
              "reference_transverse_um",
              "shift_axial_um",
              "shift_transverse_um",
              "rhat_axial",
              "rhat_transverse",
              "converged"};
  nlohmann::json curve = nlohmann::json::array();
  for (std::size_t k = 0; k < o.forces_pN.size(); ++k) {
    const double* f = all.data() + k * kForceFields;
    const bool stats = f[kHaveStats] != 0;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    auto v = [&](double x) { return stats ? x : nan; };
    t.rows.push_back({f[kForce], v(f[kAxial]), v(f[kAxialError]), v(f[kTransverse]),
                      v(f[kTransverseError]), f[kRefAxial], f[kRefTransverse],
                      v(f[kAxial] - f[kRefAxial]), v(f[kTransverse] - f[kRefTransverse]),
                      v(f[kRhatAxial]), v(f[kRhatTransverse]), f[kConverged]});
    curve.push_back({{"force_pN", f[kForce]},
                     {"axial_um", v(f[kAxial])},
                     {"axial_error_um", v(f[kAxialError])},
                     {"transverse_um", v(f[kTransverse])},
                     {"transverse_error_um", v(f[kTransverseError])},
                     {"reference_axial_um", f[kRefAxial]},
                     {"reference_transverse_um", f[kRefTransverse]},
                     {"thermal_shift_axial_um", v(f[kAxial] - f[kRefAxial])},
                     {"thermal_shift_axial_error_um", v(f[kAxialError])},
                     {"thermal_shift_transverse_um", v(f[kTransverse] - f[kRefTransverse])},
                     {"thermal_shift_transverse_error_um", v(f[kTransverseError])},
                     {"rhat_axial", v(f[kRhatAxial])},
                     {"rhat_transverse", v(f[kRhatTransverse])},
                     {"converged", f[kConverged] != 0},
                     {"directory", o.out.empty() ? "" : force_name(k)}});
  }
  nlohmann::json j = o.record.is_object() ? o.record : nlohmann::json::object();
  j.update({{"vertices", net.topo.num_vertices},
            {"temperature_K", o.sampling_temperature()},
            {"sampler", to_string(o.algorithm)},
            {"seed", o.seed},
            {"chains", o.chains},
            {"sweeps", o.sweeps},
            {"mpi_ranks", ranks},
            {"curve", curve}});
  if (!o.out.empty()) {
    write_csv(o.out + "/thermal_curve.csv", t);
    write_text_atomic(o.out + "/thermal_curve.json", j.dump(2) + "\n");
  }
  if (o.json) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << "thermal curve: " << o.forces_pN.size() << " forces, " << o.chains
            << " chains each, " << ranks << " MPI rank" << (ranks == 1 ? "" : "s") << "\n";
  for (const auto& row : curve)
    std::cout << "  F = " << row["force_pN"].get<double>() << " pN: D_A "
              << (row["axial_um"].is_number()
                      ? format_with_error(row["axial_um"].get<double>(),
                                          row["axial_error_um"].get<double>())
                      : std::string("(too few samples)"))
              << " um (0 K " << row["reference_axial_um"].get<double>() << "), D_T "
              << (row["transverse_um"].is_number()
                      ? format_with_error(row["transverse_um"].get<double>(),
                                          row["transverse_error_um"].get<double>())
                      : std::string("(too few samples)"))
              << " um (0 K " << row["reference_transverse_um"].get<double>() << ")"
              << (row["converged"].get<bool>() ? "" : ", not converged") << "\n";
  return 0;
}

/// run_mc; when it fails after run.json said "running", the manifest is rewritten as "failed"
/// with the error line's text (or removed when even that write fails), so it never says
/// "running" after the process ended.
int run_mc_recorded(const McCli& o, const GivenOptions& given) {
  if (o.resume.empty() && o.algorithm != McAlgorithm::hmc && !given.hmc_option.empty())
    throw std::invalid_argument(given.hmc_option +
                                ": an option of --sampler hmc, but the run uses --sampler " +
                                to_string(o.algorithm));
  if (!o.forces_pN.empty()) return run_mc_forces(o, given);
  McProgress made;
  try {
    return run_mc(o, given, made);
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    if (made.running)
      record_failed_manifest(o.out + "/run.json", [&] {
        write_mc_manifest(o, false, "failed", e.what(), made.sweeps_done, "");
      });
    throw;
  }
}

}  // namespace

void add_mc_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<McCli>();
  auto* cmd = app.add_subcommand(
      "mc", "Monte Carlo of the spectrin network at temperature T (Metropolis or HMC)");
  add_config_option(cmd);
  auto* vertices =
      cmd->add_option("--vertices,-n", o->vertices,
                      "vertex count N (100 to 40,000; --resume: the checkpoint's). The default is "
                      "smaller than stretch's 2,000 because a run takes thousands of sweeps of N "
                      "moves each (about 1 s per 1,000 sweeps at N = 500)")
          ->check(integer_in(100, 40000))
          ->capture_default_str();
  auto* force = cmd->add_option("--force", o->force_pN,
                                "total bead force F (pN), in [0, " +
                                    format_number(kMaxDiscreteForce_pN) + "]")
                    ->capture_default_str();
  add_model_options(cmd, o->physics);
  auto* sampling_temp =
      cmd->add_option("--sampling-temperature", o->sampling_temperature_K,
                      "temperature the chain samples at (K), in [0, 100000]; default: the WLC "
                      "--temperature, so one --temperature sets both and the chain samples the "
                      "model at its own temperature")
          ->type_name("FLOAT");
  cmd->add_option("--sweeps,-s", o->sweeps, "total sweeps (one move per vertex each)")
      ->check(integer_in(0, kMaxSweeps))
      ->capture_default_str();
  auto* seed =
      cmd->add_option("--seed", o->seed, "seed of the mt19937 streams, an integer in [0, 2^64 - 1]")
          ->check(unsigned_integer())
          ->capture_default_str();
  cmd->add_option("--streams", o->streams,
                  "RNG streams = parallel chunks, at most 1024; the chain depends on the streams, "
                  "never on the threads (0: one per OpenMP thread, so the chain then depends on "
                  "them)")
      ->check(integer_in(0, kMaxMcStreams))
      ->capture_default_str();
  auto* chains =
      cmd->add_option("--chains", o->chains,
                      "independent chains, in [1, " + std::to_string(kMaxMcChains) +
                          "], each seeded from (--seed, chain), all started at the "
                          "zero-temperature equilibrium, run one per thread and pooled (means, "
                          "errors, R-hat); fixed, so results never depend on the threads")
          ->check(integer_in(1, kMaxMcChains))
          ->capture_default_str();
  cmd->add_option("--forces", o->forces_pN,
                  "a force list F1,F2,... (pN): each force run with its chains (seeds from "
                  "(--seed, force index, chain)), spread over the MPI ranks under mpirun; "
                  "writes DIR/force_KK/ per force, DIR/thermal_curve.csv/.json and a "
                  "checkpoint per force in DIR/checkpoints/ (every --checkpoint-every sweeps); "
                  "--resume DIR continues the list")
      ->delimiter(',')
      ->type_name("FLOAT");
  auto* adapt_fraction =
      cmd->add_option("--adapt-fraction", o->adapt_fraction,
                      "fraction of the sweeps with adaptive step (equilibration), in [0, 1)")
          ->capture_default_str();
  cmd->add_option("--adapt-sweeps", o->adapt_sweeps,
                  "sweeps with adaptive step, absolute (overrides --adapt-fraction; a run extended "
                  "by --resume then matches a straight run of the new length bit for bit)");
  cmd->add_option("--sample-every", o->sample_every, "sweeps between recorded samples")
      ->check(integer_in(1, std::numeric_limits<int>::max()))
      ->capture_default_str();
  auto* sampler =
      cmd->add_option("--sampler", o->algorithm,
                      "metropolis: single-vertex moves, the reference sampler (a sweep offers "
                      "every vertex one move); hmc: Hamiltonian Monte Carlo of all vertices "
                      "with the zero-temperature Hessian as mass matrix (a sweep is one "
                      "trajectory; needs a sampling temperature > 0)")
          ->transform(enum_choice<McAlgorithm>(
              {{"metropolis", McAlgorithm::metropolis}, {"hmc", McAlgorithm::hmc}}))
          ->type_name("TEXT")
          ->default_str("metropolis");
  cmd->add_option("--hmc-step", o->hmc.step,
                  "hmc: initial leapfrog step (dimensionless time; adapted during the adaptive "
                  "sweeps towards 65 % acceptance), in (0, 4]")
      ->capture_default_str();
  cmd->add_option("--hmc-trajectory-time", o->hmc.trajectory_time,
                  "hmc: trajectory duration (dimensionless time; pi/2 decorrelates every mode of "
                  "the harmonic approximation), jittered by +-20 %, in (0, 100]")
      ->capture_default_str();
  cmd->add_option("--hmc-mass", o->hmc.projected_mass,
                  "hmc: mass matrix from the exact Hessian at the start where it factorises "
                  "(exact), or from the element-wise projected one (projected)")
      ->transform(enum_choice<bool>({{"exact", false}, {"projected", true}}))
      ->type_name("TEXT")
      ->default_str("exact");
  cmd->add_option("--hmc-mass-shift", o->hmc.mass_shift_fraction,
                  "hmc: diagonal shift of the mass matrix as a fraction of its mean diagonal, in "
                  "[1e-8, 1]")
      ->capture_default_str();
  cmd->add_option("--hmc-mass-reference", o->hmc.mass_reference,
                  "hmc: positions the mass matrix is built at: the zero-temperature equilibrium "
                  "for the whole run (equilibrium), or rebuilt once at the end of the adaptive "
                  "sweeps at the mean positions of their second half (thermal; needs >= 2 "
                  "adaptive sweeps)")
      ->transform(enum_choice<HmcMassReference>(
          {{"equilibrium", HmcMassReference::equilibrium}, {"thermal", HmcMassReference::thermal}}))
      ->type_name("TEXT")
      ->default_str("equilibrium");
  cmd->add_option("--hmc-area-volume", o->hmc.area_volume,
                  "hmc: the cell's area and volume held exactly, by constraints (exact: the "
                  "law of infinitely stiff penalties), or by the penalties of the Metropolis "
                  "sampler's law (penalty, stiffened by --penalty-scale; they cap the step)")
      ->transform(enum_choice<HmcAreaVolume>(
          {{"penalty", HmcAreaVolume::penalty}, {"exact", HmcAreaVolume::exact}}))
      ->type_name("TEXT")
      ->default_str("exact");
  cmd->add_option("--start", o->start, "equilibrium | rest")
      ->transform(
          enum_choice<McStart>({{"equilibrium", McStart::equilibrium}, {"rest", McStart::rest}}))
      ->type_name("TEXT")
      ->default_str("equilibrium");
  auto* penalty =
      cmd->add_option("--penalty-scale", o->penalty_scale,
                      "multiplies the area/volume penalty stiffnesses while sampling (thermal "
                      "drift of A and V falls as 1/sqrt)")
          ->capture_default_str();
  cmd->add_option("--checkpoint", o->checkpoint,
                  "write the chain state to FILE (HDF5, atomic); a force list (--forces) keeps "
                  "its checkpoints in --out DIR instead")
      ->check(nonempty_path());
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "sweeps between checkpoints")
      ->check(integer_in(1, kMaxSweeps))
      ->capture_default_str();
  cmd->add_option("--resume", o->resume,
                  "continue the chain stored in FILE; with --forces: continue the force list in "
                  "DIR (its --out) with the same options: finished forces are kept, the others "
                  "continue from their checkpoints");
  cmd->add_option("--out", o->out,
                  "write DIR/mc_series.csv/.h5, mc_summary.json, snapshots (.h5/.xdmf)")
      ->check(nonempty_path());
  cmd->add_option("--snapshot-every", o->snapshot_every,
                  "sweeps between snapshots (0: start and end)")
      ->check(integer_in(0, kMaxSweeps))
      ->capture_default_str();
  cmd->add_flag("--force-overwrite", o->overwrite,
                "allow a non-empty --out (with --resume, a directory holding an mc run is "
                "accepted without it)");
  cmd->add_flag("!--no-picture", o->picture,
                "with --out: no cells.png (the first and the last snapshot, drawn as rbc render "
                "draws them)");
  cmd->add_flag("--json", o->json,
                "print the run as JSON: {command, config, provenance, threads, the run's keys and "
                "statistics}");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress on stderr");
  add_verbose_flag(cmd, o->verbose);
  cmd->callback([o, cmd, force, sampling_temp, seed, penalty, vertices, adapt_fraction, sampler,
                 chains, &action] {
    GivenOptions given{force->count() > 0,
                       sampling_temp->count() > 0 || cmd->get_option("--temperature")->count() > 0,
                       seed->count() > 0,
                       penalty->count() > 0,
                       vertices->count() > 0,
                       cmd->get_option("--bending")->count() > 0,
                       adapt_fraction->count() > 0,
                       sampler->count() > 0,
                       chains->count() > 0,
                       cmd->get_option("--hmc-area-volume")->count() > 0,
                       {}};
    for (const CLI::Option* opt : cmd->get_options())
      if (opt->count() > 0 && opt->get_name().rfind("--hmc-", 0) == 0 && given.hmc_option.empty())
        given.hmc_option = opt->get_name();
    o->sampling_temperature_given = sampling_temp->count() > 0;
    action = [o, cmd, given] {
      o->record = run_record(*cmd);
      make_cancellable();  // polls interrupt_check(): see app/interrupt.hpp
      return naming_options(mc_option_names(), [&] { return run_mc_recorded(*o, given); });
    };
  });
}

}  // namespace rbc::app
