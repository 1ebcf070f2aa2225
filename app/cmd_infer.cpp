// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer`: Bayesian calibration of the spectrin parameters from force-diameter data
// (MODEL.md section 7; calibrate/infer.hpp). Under mpirun every rank runs this command; rank 0
// samples and writes, the others serve forward runs (calibrate/mpi_executor.hpp).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <iterator>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/interrupt.hpp"
#include "app/model_options.hpp"
#include "app/run_config.hpp"
#include "calibrate/infer.hpp"
#include "calibrate/laplace_is_checkpoint.hpp"
#include "calibrate/mpi_executor.hpp"
#include "calibrate/predictive.hpp"
#include "calibrate/recovery_prediction.hpp"
#include "calibrate/sensitivity.hpp"
#include "calibrate/stage_checkpoint.hpp"
#include "core/cpu_time.hpp"
#include "core/io.hpp"
#include "core/validation.hpp"

namespace rbc::app {

void check_output_directory(const std::string& dir, bool overwrite);  // cmd_fig7.cpp

namespace {
struct InferCli {
  std::vector<std::string> data_files;  ///< --data-file, repeatable: one experiment each
  std::string method = "continuum:2:2000", params = "persistence,lmax,sigma-scale";
  std::vector<std::string> priors;
  /// --extra-uncertainty UM (every file) or STEM=UM (the file of that stem), repeatable.
  std::vector<std::string> extra_uncertainty;
  std::string per_experiment;                               ///< --per-experiment NAME[,NAME...]
  int recovery_elements = RecoveryModelOptions{}.elements;  ///< --recovery-elements
  int samples = InferOptions::default_sampler().samples;
  int chain_length = InferOptions::default_sampler().chain_length;
  double target_cov = 1.0, proposal_scale = 0.2;
  std::uint64_t seed = 1;
  int threads = 0;
  SamplerKind sampler = InferOptions{}.sampler_kind;      ///< --sampler
  int is_samples = InferOptions{}.is_samples;             ///< --is-samples (laplace-is)
  int is_rounds = InferOptions{}.is_rounds;               ///< --is-rounds (laplace-is)
  double min_ess = InferOptions{}.min_effective_samples;  ///< --min-ess (laplace-is)
  double force_tolerance_pN = ForwardOptions::default_newton().force_tolerance_pN;
  Symmetry symmetry = ForwardOptions::default_newton().symmetry;
  std::string out, resume;
  bool json = false, overwrite = false, quiet = false, verbose = false, forward_check = false,
       trace = false;
  int repeat = 1;  ///< --forward-check: warm sweeps timed (median reported)
  std::vector<std::string> at;
  ModelCli physics;  ///< the model option group: the values of the parameters not inferred
  // Held-out prediction (calibrate/predictive.hpp).
  std::vector<std::string> predict;             ///< --predict FILE, repeatable
  int predict_draws = kDefaultPredictiveDraws;  ///< --predict-draws (0: every sample)
  /// --predict-recovery-draws (0: every sample): draws for a recovery --predict file
  int predict_recovery_draws = kDefaultRecoveryPredictiveDraws;
  std::string candidate_forces;  ///< --candidate-forces (pN), empty: none
};

/// The model option group's values as the forward model's fixed parameters. The forward model
/// varies persistence, Lmax, kappa and the contact fraction; the group's other options keep the
/// values it is built with (the paper's), so another value is refused rather than ignored, and
/// so is a value for a parameter that is inferred (its prior box gives its range).
ForwardParameters fixed_parameters(const ModelCli& m, const std::vector<Parameter>& inferred) {
  const ModelCli paper;
  const std::string unsupported =
      "rbc infer's forward model keeps the paper's value; expected the default";
  auto refuse_other = [](const std::string& option, double value, const std::string& why) {
    throw std::invalid_argument(option + " " + format_number(value) + ": " + why);
  };
  auto refuse_fixed = [&](const std::string& option, double value, double paper_value) {
    refuse_other(option, value, unsupported + " " + format_number(paper_value));
  };
  if (m.lbar_nm != paper.lbar_nm) refuse_fixed("--lbar", m.lbar_nm, paper.lbar_nm);
  if (m.temperature_K != paper.temperature_K)
    refuse_fixed("--temperature", m.temperature_K, paper.temperature_K);
  if (m.h0_per_um != paper.h0_per_um) refuse_fixed("--h0", m.h0_per_um, paper.h0_per_um);
  if (m.q != paper.q) refuse_fixed("--q", m.q, paper.q);
  if (m.eta != paper.eta) refuse_fixed("--eta", m.eta, paper.eta);
  if (m.contact != paper.contact)
    throw std::invalid_argument("--contact vertices: " + unsupported + " area");
  if (m.bending != paper.bending)
    throw std::invalid_argument("--bending dihedral: " + unsupported + " juelicher");
  if (m.dihedral_mapping != paper.dihedral_mapping)
    throw std::invalid_argument("--dihedral-mapping li: " + unsupported + " sphere");
  ForwardParameters f;
  f.persistence_nm = m.persistence_nm;
  f.lmax_nm = m.lmax_nm;
  f.kappa_J = m.kappa_J;
  f.contact_fraction = m.contact_fraction;
  const ForwardParameters defaults;
  struct Given {
    Parameter parameter;
    const char* option;
    double value, paper;
  };
  const Given given[] = {
      {Parameter::persistence, "--persistence", f.persistence_nm, defaults.persistence_nm},
      {Parameter::lmax, "--lmax", f.lmax_nm, defaults.lmax_nm},
      {Parameter::kappa, "--kappa", f.kappa_J, defaults.kappa_J},
      {Parameter::contact_fraction, "--contact-fraction", f.contact_fraction,
       defaults.contact_fraction}};
  for (const Given& g : given)
    if (g.value != g.paper &&
        std::find(inferred.begin(), inferred.end(), g.parameter) != inferred.end())
      refuse_other(g.option, g.value,
                   to_string(g.parameter) + " is inferred (--params); set its range with --prior " +
                       to_string(g.parameter) + "=LO:HI");
  // Each value in the forward model's range (ForwardParameters::validate), named as its option.
  struct Range {
    const char* option;
    double value;
    bool ok;
    const char* expected;
  };
  const Range ranges[] = {
      {"--persistence", f.persistence_nm, f.persistence_nm > 0 && std::isfinite(f.persistence_nm),
       "expected a persistence length > 0 nm"},
      {"--lmax", f.lmax_nm, f.lmax_nm > 75.0 && std::isfinite(f.lmax_nm),
       "expected Lmax > Lbar = 75 nm"},
      {"--kappa", f.kappa_J, f.kappa_J > 0 && std::isfinite(f.kappa_J),
       "expected a bending rigidity > 0 J"},
      {"--contact-fraction", f.contact_fraction, f.contact_fraction > 0 && f.contact_fraction < 0.5,
       "expected a contact fraction in (0, 0.5)"}};
  for (const Range& r : ranges)
    if (!r.ok) refuse_other(r.option, r.value, r.expected);
  return f;
}

/// This process's command line ("rbc infer ..."), from /proc/self/cmdline (Linux); empty
/// elsewhere. Recorded in summary.json so a cached result says how it was made.
std::string own_command_line() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string out;
  bool first = true;
  for (size_t b = 0; b < all.size();) {
    size_t e = all.find('\0', b);
    if (e == std::string::npos) e = all.size();
    std::string arg = all.substr(b, e - b);
    if (first)
      arg = "rbc";
    else if (arg.find_first_of(" \t\"'") != std::string::npos)
      arg = "'" + arg + "'";
    out += (first ? "" : " ") + arg;
    first = false;
    b = e + 1;
  }
  return out;
}

/// Parses "persistence=12" into the forward parameters (natural units).
void apply_at(const std::string& text, ForwardParameters& p) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos)
    throw std::invalid_argument("--at '" + text + "' is not of the form NAME=VALUE");
  const Parameter which = parameter_from_string(text.substr(0, eq));
  const std::vector<double> v =
      parse_number_list(text.substr(eq + 1), "--at " + text.substr(0, eq), "12.5", false);
  if (v.size() != 1) throw std::invalid_argument("--at '" + text + "': one value expected");
  switch (which) {
    case Parameter::persistence:
      p.persistence_nm = v[0];
      break;
    case Parameter::lmax:
      p.lmax_nm = v[0];
      break;
    case Parameter::kappa:
      p.kappa_J = v[0];
      break;
    case Parameter::contact_fraction:
      p.contact_fraction = v[0];
      break;
    case Parameter::sigma_scale:
    case Parameter::eta_m:
    case Parameter::tau:
    case Parameter::eta_spread:
      throw std::invalid_argument("--at " + to_string(which) +
                                  ": not a stretch forward-model parameter");
  }
  p.validate();
}

/// --forward-check: one cold and one warm forward sweep at the --at parameters, with times.
int forward_check(const InferenceProblem& problem, const ForwardParameters& at, bool trace,
                  int repeat) {
  using Clock = std::chrono::steady_clock;
  const ProgressSink sink = stderr_progress(!trace);
  const auto t0 = Clock::now();
  report(sink, "cold sweep:");
  const ForwardRun cold = problem.forward().run(at, {}, sink);
  const double cold_s = std::chrono::duration<double>(Clock::now() - t0).count();
  ForwardParameters near = at;
  near.persistence_nm *= 1.01;  // a typical proposal step away
  report(sink, "warm sweep at p x 1.01:");
  ForwardRun warm;
  std::vector<double> warm_times_s, warm_cpu_s;
  for (int k = 0; k < repeat; ++k) {
    const auto t1k = Clock::now();
    const double c1k = process_cpu_seconds();
    warm = problem.forward().run(near, cold.state, k == 0 ? sink : ProgressSink{});
    warm_cpu_s.push_back(process_cpu_seconds() - c1k);
    warm_times_s.push_back(std::chrono::duration<double>(Clock::now() - t1k).count());
  }
  std::sort(warm_times_s.begin(), warm_times_s.end());
  std::sort(warm_cpu_s.begin(), warm_cpu_s.end());
  std::cout << "# " << problem.options().method.name() << ", " << problem.forward().vertices()
            << " vertices; p = " << at.persistence_nm << " nm, Lmax = " << at.lmax_nm
            << " nm, kappa = " << at.kappa_J << " J, contact fraction " << at.contact_fraction
            << "\n# force_pN axial_um transverse_um data_axial_um data_transverse_um\n";
  for (size_t k = 0; k < cold.diameters.axial_um.size(); ++k)
    std::cout << std::setprecision(6) << problem.data().force_pN[k] << " "
              << cold.diameters.axial_um[k] << " " << cold.diameters.transverse_um[k] << " "
              << problem.data().axial_um[k] << " " << problem.data().transverse_um[k] << "\n";
  const double warm_s = warm_times_s[warm_times_s.size() / 2];  // median of --repeat
  const double warm_cpu = warm_cpu_s[warm_cpu_s.size() / 2];
  std::cout << "cold sweep " << cold_s << " s (" << (cold.converged ? "converged" : "FAILED")
            << (cold.retried ? ", retried" : "") << "), warm sweep at p x 1.01 " << warm_s << " s ("
            << (warm.converged ? "converged" : "FAILED") << (warm.retried ? ", retried" : "")
            << (repeat > 1 ? ", median of " + std::to_string(repeat) : std::string()) << ", "
            << warm_cpu << " s cpu), " << cold.solves << " and " << warm.solves << " solves\n";
  for (const ForwardRun* r : {&cold, static_cast<const ForwardRun*>(&warm)})
    if (!r->converged)
      std::cout << (r == &cold ? "cold" : "warm") << " sweep failed at F = " << r->failed_force_pN
                << " pN: " << r->failure << "\n";
  if (!cold.converged) {
    std::cerr << "rbc: error: forward run did not converge, residual " << std::scientific
              << cold.residual_pN << " pN\n";
    return 1;
  }
  return 0;
}

/// --extra-uncertainty's values: "UM" sets every file's, "STEM=UM" one file's (the file whose
/// name without directory and extension is STEM); a bare value at most once.
void apply_extra_uncertainty(const std::vector<std::string>& values, InferOptions& o) {
  bool bare = false;
  for (const std::string& text : values) {
    const size_t eq = text.find('=');
    const std::string number = eq == std::string::npos ? text : text.substr(eq + 1);
    const std::optional<double> v = parse_finite_number(number);
    // A bare negative value reaches InferOptions::validate, which names it.
    if (!v || (*v < 0 && eq != std::string::npos))
      throw std::invalid_argument("--extra-uncertainty " + text +
                                  ": expected UM or FILE_STEM=UM, an uncertainty >= 0 um");
    if (eq == std::string::npos) {
      if (bare)
        throw std::invalid_argument("--extra-uncertainty " + text +
                                    ": a value for every file is given twice; name a file as "
                                    "FILE_STEM=UM");
      bare = true;
      o.extra_uncertainty_um = *v;
    } else {
      if (eq == 0)
        throw std::invalid_argument("--extra-uncertainty " + text +
                                    ": expected FILE_STEM=UM with a file stem before '='");
      o.extra_uncertainty_by_file.push_back({text.substr(0, eq), *v});
    }
  }
}

InferOptions to_options(const InferCli& c) {
  InferOptions o;
  if (c.data_files.size() == 1)
    o.data_file = c.data_files.front();
  else
    o.data_files = c.data_files;
  o.method = parse_method(c.method);
  o.parameters = parse_parameter_list(c.params);
  for (const auto& p : c.priors) o.priors.push_back(parse_prior(p));
  apply_extra_uncertainty(c.extra_uncertainty, o);
  if (!c.per_experiment.empty()) {
    try {
      o.per_experiment = parse_parameter_list(c.per_experiment);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("--per-experiment " + c.per_experiment + ": " + e.what());
    }
  }
  o.recovery_model.elements = c.recovery_elements;
  if (c.recovery_elements != RecoveryModelOptions{}.elements) {
    const std::vector<std::string> files =
        c.data_files.empty() ? std::vector<std::string>{o.data_path()} : c.data_files;
    // A recovery --predict file runs the release scene too (a file that cannot be read is
    // named by --predict's own check).
    const auto predicted_recovery = [](const std::string& f) {
      try {
        return detect_data_kind(f) == DataKind::recovery;
      } catch (const std::exception&) {
        return false;
      }
    };
    if (std::none_of(
            files.begin(), files.end(),
            [](const std::string& f) { return detect_data_kind(f) == DataKind::recovery; }) &&
        std::none_of(c.predict.begin(), c.predict.end(), predicted_recovery))
      throw std::invalid_argument("--recovery-elements " + std::to_string(c.recovery_elements) +
                                  ": no recovery data file among --data-file or --predict "
                                  "(expected one, or leave the option out)");
    try {
      o.recovery_model.validate();
    } catch (const std::exception& e) {
      throw std::invalid_argument("--recovery-elements " + std::to_string(c.recovery_elements) +
                                  ": " + e.what());
    }
  }
  o.sampler.samples = c.samples;
  o.sampler.chain_length = c.chain_length;
  o.sampler.target_cov = c.target_cov;
  o.sampler.proposal_scale = c.proposal_scale;
  o.sampler.seed = c.seed;
  o.sampler.cancel = interrupt_check();  // polled between stages and between chains
  o.sampler_kind = c.sampler;
  o.is_samples = c.is_samples;
  o.is_rounds = c.is_rounds;
  o.min_effective_samples = c.min_ess;
  o.fixed = fixed_parameters(c.physics, o.parameters);
  o.threads = c.threads;
  o.force_tolerance_pN = c.force_tolerance_pN;
  o.symmetry = c.symmetry;
  o.validate();
  return o;
}

/// The output directory of the run (--resume DIR: DIR), checked before any work: a resumed
/// run's directory must hold a checkpoint; a new run's must be empty (--force-overwrite aside)
/// and, when it holds a checkpoint, the message names --resume.
std::string checked_output_directory(const InferCli& c) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (c.resume.empty()) {
    if (!c.out.empty() && !c.overwrite && fs::exists(fs::path(c.out) / kStageCheckpointName, ec))
      throw std::invalid_argument("--out " + c.out +
                                  ": holds the checkpoint of an earlier run; continue it with "
                                  "--resume " +
                                  c.out + " or start anew with --force-overwrite");
    if (!c.out.empty()) check_output_directory(c.out, c.overwrite);
    return c.out;
  }
  if (c.forward_check) throw std::invalid_argument("--resume: not with --forward-check");
  if (!c.out.empty() && fs::weakly_canonical(c.out, ec) != fs::weakly_canonical(c.resume, ec))
    throw std::invalid_argument("--out " + c.out +
                                ": a resumed run writes into its own "
                                "directory " +
                                c.resume + " (leave --out out)");
  if (!fs::is_directory(c.resume, ec))
    throw std::invalid_argument("--resume " + c.resume + ": no such directory");
  if (!fs::is_regular_file(fs::path(c.resume) / kStageCheckpointName, ec))
    throw std::invalid_argument("--resume " + c.resume + ": no " + kStageCheckpointName +
                                " in it (rbc infer --out DIR writes one after every stage)");
  prepare_output_directory(c.resume, false, /*allow_nonempty=*/true);
  return c.resume;
}

/// Removes the temporaries of checkpoint writes a killed run left behind (best effort).
void remove_stale_checkpoint_temporaries(const std::string& dir) {
  namespace fs = std::filesystem;
  const std::string prefix = "." + std::string(kStageCheckpointName) + ".partial";
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().filename().string().rfind(prefix, 0) == 0 && e.is_regular_file(ec))
      fs::remove(e.path(), ec);
}

// --- Held-out prediction (--predict) ---------------------------------------------------------

/// The --predict files prepared against the fit's problem, checked before any work: each must
/// read as stretch data for the fit's method or as recovery data (detect_data_kind), differ
/// from the fit's data files and from the other --predict files. The recovery files go to
/// `recovery`.
std::vector<std::unique_ptr<PredictionProblem>> prediction_problems(
    const InferCli& c, const InferenceProblem& fit,
    std::vector<std::unique_ptr<RecoveryPredictionProblem>>& recovery) {
  namespace fs = std::filesystem;
  if (c.predict_draws < 0)
    throw std::invalid_argument("--predict-draws " + std::to_string(c.predict_draws) +
                                ": expected a number of posterior draws >= 0 (0: every sample)");
  if (c.predict_recovery_draws < 0)
    throw std::invalid_argument("--predict-recovery-draws " +
                                std::to_string(c.predict_recovery_draws) +
                                ": expected a number of posterior draws >= 0 (0: every sample)");
  if (!c.predict.empty() && c.forward_check)
    throw std::invalid_argument("--predict " + c.predict.front() + ": not with --forward-check");
  std::vector<std::unique_ptr<PredictionProblem>> out;
  for (size_t i = 0; i < c.predict.size(); ++i) {
    const std::string& path = c.predict[i];
    std::error_code ec;
    for (size_t j = 0; j < i; ++j)
      if (path == c.predict[j] || fs::equivalent(path, c.predict[j], ec))
        throw std::invalid_argument("--predict " + path + ": given twice");
    try {
      // A file that cannot be read is named by the stretch reader ("cannot open").
      const auto kind = [&] {
        try {
          return detect_data_kind(path);
        } catch (const std::exception&) {
          return DataKind::stretch;
        }
      };
      if (kind() == DataKind::recovery)
        recovery.push_back(std::make_unique<RecoveryPredictionProblem>(fit, path));
      else
        out.push_back(std::make_unique<PredictionProblem>(fit, path));
    } catch (const std::exception& e) {
      const std::string what = e.what();
      if (what.rfind("--predict", 0) == 0) throw;
      throw std::invalid_argument("--predict " + path + ": " + what);
    }
  }
  return out;
}

/// Predicts every --predict file from the fit with the executor `make` gives for each (empty:
/// OpenMP threads), calling `done` after each, and puts the "predictions" into the result.
std::vector<HeldOutPrediction> predict_all(
    const std::vector<std::unique_ptr<PredictionProblem>>& problems, InferenceResult& r, int draws,
    const ProgressSink& progress,
    const std::function<Executor(const PredictionProblem&)>& make = {},
    const std::function<void()>& done = {}) {
  std::vector<HeldOutPrediction> out;
  for (const auto& p : problems) {
    out.push_back(predict_held_out(*p, r, draws, make ? make(*p) : Executor{}, progress));
    if (done) done();
  }
  if (!out.empty()) r.predictions = predictions_json(out);
  return out;
}

/// Predicts every recovery --predict file (as predict_all) and appends its "predictions" entry.
std::vector<RecoveryPrediction> predict_all_recovery(
    const std::vector<std::unique_ptr<RecoveryPredictionProblem>>& problems, InferenceResult& r,
    int draws, const ProgressSink& progress,
    const std::function<Executor(const RecoveryPredictionProblem&)>& make = {},
    const std::function<void()>& done = {}) {
  std::vector<RecoveryPrediction> out;
  for (const auto& p : problems) {
    out.push_back(predict_recovery(*p, r, draws, make ? make(*p) : Executor{}, progress));
    if (done) done();
    if (r.predictions.is_null()) r.predictions = nlohmann::json::array();
    r.predictions.push_back(recovery_prediction_json(out.back()));
  }
  return out;
}

/// Output stems of the recovery predictions: predict_<file stem>, unique among every
/// prediction's (the stretch ones keep prediction_file_stems').
std::vector<std::string> recovery_prediction_stems(
    const std::vector<HeldOutPrediction>& stretch,
    const std::vector<RecoveryPrediction>& recovery) {
  std::vector<std::string> paths;
  for (const auto& p : stretch) paths.push_back(p.path);
  for (const auto& p : recovery) paths.push_back(p.path);
  const std::vector<std::string> all = prediction_file_stems(paths);
  return {all.begin() + static_cast<long>(stretch.size()), all.end()};
}

void print_recovery_predictions(const std::vector<RecoveryPrediction>& predictions) {
  for (const RecoveryPrediction& p : predictions) {
    std::cout << "  held out: recovery data " << p.path << ", " << p.draws << " posterior draws ("
              << p.eta_m_text()
              << "; each cell's lambda_0, lambda_inf at each draw: the mode of the likelihood's "
                 "fit to its own readings)\n"
              << std::fixed << std::setprecision(2);
    for (const RecoveryCellPrediction& c : p.cells)
      std::cout << "    cell " << c.id << ": inside the 50 % band " << c.in_50 << "/" << c.points()
                << ", inside the 90 % band " << c.in_90 << "/" << c.points() << "\n";
    std::cout << "    all cells: " << p.fraction_50() << " inside the 50 % band, "
              << p.fraction_90() << " inside the 90 % band; t_c = eta_m/mu " << std::setprecision(3)
              << p.tc_q50_s << " s (90 %: " << p.tc_q05_s << " to " << p.tc_q95_s << " s)\n"
              << std::defaultfloat;
  }
}

void print_predictions(const std::vector<HeldOutPrediction>& predictions) {
  for (const HeldOutPrediction& p : predictions) {
    const PredictiveCoverage& c = p.coverage;
    std::cout << "  held out: " << p.data.name << " (" << p.path << "), " << p.draws
              << " posterior draws\n"
              << "    inside the 50 % band: " << c.axial_in_50 << "/" << c.axial_points << " D_A, "
              << c.transverse_in_50 << "/" << c.transverse_points << " D_T, " << std::fixed
              << std::setprecision(2) << c.fraction_50()
              << " of all; inside the 90 % band: " << c.axial_in_90 << "/" << c.axial_points
              << " D_A, " << c.transverse_in_90 << "/" << c.transverse_points << " D_T, "
              << c.fraction_90() << " of all\n"
              << std::defaultfloat;
  }
}
// --- end of held-out prediction ----------------------------------------------------------------
/// --candidate-forces as forces (pN), checked before any work: a list of numbers within the
/// method's documented force range.
std::vector<double> candidate_forces(const InferCli& c, const InferOptions& o) {
  if (c.candidate_forces.empty()) return {};
  std::vector<double> f =
      parse_number_list(c.candidate_forces, "--candidate-forces", "20,250 in pN", false);
  for (double v : f)
    if (v > max_method_force_pN(o.method.kind)) {
      std::ostringstream m;
      m << "--candidate-forces " << c.candidate_forces << ": expected forces in [0, "
        << max_method_force_pN(o.method.kind) << "] pN (the model's documented range), got " << v;
      throw std::invalid_argument(m.str());
    }
  return f;
}

/// The identifiability report at the posterior median (calibrate/sensitivity.hpp). A failure
/// here is reported in the report's status: the posterior stands.
IdentifiabilityReport median_identifiability(const InferenceProblem& problem,
                                             const InferenceResult& r,
                                             const std::vector<double>& candidates,
                                             const ProgressSink& progress) {
  std::vector<double> median;
  for (const auto& s : r.parameters) median.push_back(s.q50);
  report(progress, "identifiability at the posterior median");
  try {
    IdentifiabilityReport id = identifiability(problem, median, candidates);
    id.point_label = "the posterior median";
    return id;
  } catch (const std::exception& e) {
    IdentifiabilityReport failed;
    failed.status = std::string("failed: ") + e.what();
    failed.at = median;
    failed.point_label = "the posterior median";
    return failed;
  }
}

void print_summary(const InferenceResult& r) {
  const int tempering = static_cast<int>(r.stages.size()) - 1;
  if (r.sampler == "laplace-is")
    std::cout << "posterior (" << r.method << ", laplace-is: " << r.newton_steps
              << " Newton steps from the prior centre, " << r.samples_per_stage
              << " importance samples"
              << (r.is_rounds > 1 ? " in " + std::to_string(r.is_rounds) + " rounds" : "")
              << ", effective " << std::setprecision(4) << r.ess << ", seed " << r.seed << "):\n";
  else
    std::cout << "posterior (" << r.method << ", " << r.samples_per_stage << " samples per stage, "
              << "stage 0 (prior) and " << tempering << " tempering stage"
              << (tempering == 1 ? "" : "s") << ", seed " << r.seed << "):\n";
  if (r.experiments.size() > 1)
    for (const auto& e : r.experiments)
      std::cout << "  data: " << (e.kind == "recovery" ? "recovery curves" : e.data.name) << " ("
                << e.path << ")"
                << (e.kind == "recovery" ? std::string() : ", sigma: " + sigma_text(e.data))
                << "\n";
  else
    std::cout << "  data: " << r.data.name << " (" << r.data_file << ")\n"
              << "  sigma: " << sigma_text(r.data) << "\n";
  auto line = [](const Summary& s) {
    std::cout << "  " << std::left << std::setw(18)
              << s.name + (s.unit == "1" ? "" : " (" + s.unit + ")") << std::right
              << std::setprecision(4) << " mean " << std::setw(10) << s.mean << "  sd "
              << std::setw(10) << s.sd << "  90 % [" << s.q05 << ", " << s.q95 << "]  median "
              << s.q50 << "\n";
  };
  for (const auto& s : r.parameters) line(s);
  line(r.mu);
  line(r.K);
  std::cout << "  log evidence " << format_with_error(r.log_evidence, r.log_evidence_sd)
            << "\n  forward runs " << r.counts.runs << " (retried " << r.counts.retried
            << ", failed " << r.counts.failed << "), " << std::setprecision(1) << std::fixed
            << r.wall_s << " s\n";
}
}  // namespace

void add_infer_command(CLI::App& app, Action& action) {
  auto c = std::make_shared<InferCli>();
  auto* cmd = app.add_subcommand("infer",
                                 "Bayesian calibration (laplace-is or TMCMC) of the spectrin "
                                 "parameters from force-diameter and recovery data");
  add_config_option(cmd);
  cmd->add_option("--data-file", c->data_files,
                  "stretch-data CSV: force_pN,axial_um,axial_err_um,transverse_um,"
                  "transverse_err_um, optional '# name:' and '# extra_uncertainty_um:' "
                  "comment lines (default: data/suresh2005_healthy_optical_tweezers.csv); "
                  "repeatable: several experiments in one posterior, the likelihood the sum of "
                  "theirs, each with its own error bars (file names must differ)")
      ->type_name("FILE");
  cmd->add_option("--method", c->method, "forward model: discrete:N or continuum:ORDER:ELEMENTS")
      ->capture_default_str();
  cmd->add_option("--params", c->params,
                  "inferred parameters from persistence (nm), lmax (nm), kappa (J), "
                  "contact-fraction, sigma-scale, tau (um: the between-experiment sd of a "
                  "per-experiment offset of D_A and of D_T, marginalised; prior 0:1), eta-m "
                  "(pN s/um, recovery data only), eta-spread (the between-cell sd of log eta_m, "
                  "each recovery cell at its own viscosity, integrated out; with eta-m)")
      ->capture_default_str();
  cmd->add_option("--prior", c->priors,
                  "uniform prior NAME=LOWER:UPPER, repeatable (defaults: persistence=2:40, "
                  "lmax=150:300, kappa=5e-20:1e-18, contact-fraction=0.02:0.15, "
                  "sigma-scale=0.2:3, tau=0:1, eta-m=0.2:2, eta-spread=0.01:1)");
  cmd->add_option("--extra-uncertainty", c->extra_uncertainty,
                  "uncertainty (um) added in quadrature to every error bar, on top of what the "
                  "data file declares ('# extra_uncertainty_um:'); UM for every data file or "
                  "FILE_STEM=UM for the data file of that name (without directory and "
                  "extension), repeatable; default 0: the files' error bars")
      ->type_name("TEXT");
  cmd->add_option("--per-experiment", c->per_experiment,
                  "inferred forward-model parameters (of --params) given one value per data "
                  "file, e.g. contact-fraction: parameters contact-fraction[FILE_STEM], each "
                  "with the parameter's prior; comma-separated")
      ->type_name("NAMES");
  cmd->add_option("--recovery-elements", c->recovery_elements,
                  "recovery data: continuum triangles of the release scene (" +
                      std::to_string(kMinContinuumElements) + " to " +
                      std::to_string(kMaxContinuumElements) +
                      "); a trajectory's cost grows with it, and eta_m moves 1.5 % from 400 to "
                      "1,000 on the Hochmuth cells")
      ->capture_default_str();
  cmd->add_option("--sampler", c->sampler,
                  "posterior sampler: laplace-is (a Student-t proposal at the posterior mode, "
                  "found with the likelihood's gradient, adapted to the weighted draws over "
                  "--is-rounds rounds, with importance correction: about a sixth of TMCMC's "
                  "forward runs; stops with status low_ess below --min-ess effective samples) | "
                  "tmcmc (transitional MCMC, the reference). Both give the evidence")
      ->transform(enum_choice<SamplerKind>(
          {{"tmcmc", SamplerKind::tmcmc}, {"laplace-is", SamplerKind::laplace_is}}))
      ->type_name("TEXT")
      ->default_str(to_string(InferOptions{}.sampler_kind));
  cmd->add_option(
         "--is-samples", c->is_samples,
         "laplace-is: importance samples (forward runs after the mode search), at least 10; "
         "more raise the effective sample size about in proportion")
      ->capture_default_str();
  cmd->add_option("--is-rounds", c->is_rounds,
                  "laplace-is: adaptation rounds; the importance samples are split into rounds, "
                  "each after the first drawn from a Student-t refit to the weighted draws "
                  "before it (adaptive multiple importance sampling); 1: the Laplace proposal "
                  "alone")
      ->capture_default_str();
  cmd->add_option("--min-ess", c->min_ess,
                  "laplace-is: fewest effective importance samples of an accepted posterior; "
                  "below it the run stops with status low_ess (exit 1)")
      ->capture_default_str();
  cmd->add_option(
         "--samples", c->samples,
         "tmcmc: samples per stage, at least " + std::to_string(InferOptions::minimum_samples()))
      ->capture_default_str();
  cmd->add_option("--chain-length", c->chain_length, "tmcmc: Metropolis steps per sample and stage")
      ->capture_default_str();
  cmd->add_option("--target-cov", c->target_cov,
                  "tmcmc: target coefficient of variation of the stage weights")
      ->capture_default_str();
  cmd->add_option("--proposal-scale", c->proposal_scale,
                  "tmcmc: proposal sd in units of the weighted sample sd (beta)")
      ->capture_default_str();
  cmd->add_option("--seed", c->seed,
                  "random seed, an integer in [0, 2^64 - 1] (the posterior depends on it only)")
      ->check(unsigned_integer())
      ->capture_default_str();
  cmd->add_option("--threads", c->threads, "OpenMP threads for forward runs (0: OMP_NUM_THREADS)")
      ->capture_default_str();
  cmd->add_option("--force-tolerance", c->force_tolerance_pN,
                  "Newton tolerance of the continuum forward runs: largest net vertex force (pN)")
      ->capture_default_str();
  cmd->add_option("--symmetry", c->symmetry,
                  "continuum forward runs: none | mirror (solve on the mirror-symmetric states; "
                  "the top force's is checked and, if a saddle, the forces from the first "
                  "unstable one on are solved again in full)")
      ->transform(enum_choice<Symmetry>({{"none", Symmetry::none}, {"mirror", Symmetry::mirror}}))
      ->type_name("TEXT")
      ->default_str(to_string(ForwardOptions::default_newton().symmetry));
  cmd->add_option("--out", c->out,
                  "output directory (summary, samples, corner and predictive plots; " +
                      std::string(kStageCheckpointName) +
                      " after every stage; laplace-is: after every Newton step and block of "
                      "importance draws)");
  cmd->add_option("--resume", c->resume,
                  "continue the run whose --out was DIR from its last checkpoint (TMCMC: the "
                  "last complete stage; laplace-is: the last Newton step or block of importance "
                  "draws), into DIR, to the straight run's result (repeat the run's other "
                  "options, --sampler included; threads and MPI ranks may differ)")
      ->type_name("DIR");
  cmd->add_flag("--json", c->json, "print the JSON summary on stdout");
  cmd->add_option("--candidate-forces", c->candidate_forces,
                  "forces (pN, comma-separated) to rank by the expected information gain of one "
                  "more stretch point there, in DIR/identifiability.json and the summary");
  cmd->add_flag("--forward-check", c->forward_check,
                "no inference: one cold and one warm forward sweep at the --at parameters "
                "(default the paper's), diameters and times");
  cmd->add_flag("--trace", c->trace,
                "with --forward-check: every solve and Newton iteration on stderr");
  cmd->add_option("--repeat", c->repeat,
                  "with --forward-check: warm sweeps to time (the median is printed)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--at", c->at, "forward-check parameter NAME=VALUE (natural units), repeatable");
  cmd->add_flag("--force-overwrite", c->overwrite, "allow a non-empty --out");
  cmd->add_flag("--quiet,-q", c->quiet, "no progress on stderr");
  add_verbose_flag(cmd, c->verbose);
  cmd->add_option("--predict", c->predict,
                  "held-out data CSV (the --data-file formats) to predict from the posterior: "
                  "stretch data, 5-95 % quantiles of D_A, D_T with the file's own error bars; "
                  "recovery data (cell,time_s,length_over_width), 5-95 % quantiles of each "
                  "cell's length over width with its reading noise (eta_m from its prior when "
                  "not inferred); and the fraction of the points inside the 50 % and 90 % bands "
                  "(summary.json 'predictions', predict_STEM.png); repeatable")
      ->type_name("FILE");
  cmd->add_option("--predict-draws", c->predict_draws,
                  "posterior samples drawn for a stretch --predict file (systematic resampling "
                  "with --seed; 0: every sample); one forward run per distinct sample")
      ->capture_default_str();
  cmd->add_option("--predict-recovery-draws", c->predict_recovery_draws,
                  "posterior samples drawn for a recovery --predict file (as --predict-draws); "
                  "one release trajectory per distinct sample, each about 1.4 CPU s at 1,000 "
                  "--recovery-elements")
      ->capture_default_str();
  // The physics every command shares: here the values of the parameters not inferred.
  add_model_options(cmd, c->physics);
  cmd->callback([c, &action, cmd] {
    action = [c, cmd]() -> int {
      const bool mpi = launched_by_mpirun();
      const char* rank_env = std::getenv("OMPI_COMM_WORLD_RANK");
      const bool master = !rank_env || std::string(rank_env) == "0";
      // Everything that can be wrong with the input is found here, on every rank, before MPI
      // starts and before any forward run (the checkpoint of --resume: rank 0, below, before
      // any forward run too).
      InferOptions o;
      std::unique_ptr<InferenceProblem> problem;
      std::vector<std::unique_ptr<PredictionProblem>> held_out;  // --predict
      std::vector<HeldOutPrediction> predictions;
      std::vector<std::unique_ptr<RecoveryPredictionProblem>> recovery_held_out;  // --predict
      std::vector<RecoveryPrediction> recovery_predictions;
      std::string out;
      std::vector<double> candidates;  // --candidate-forces (pN)
      try {
        o = to_options(*c);
        candidates = candidate_forces(*c, o);
        out = checked_output_directory(*c);
        problem = std::make_unique<InferenceProblem>(o);
        if (c->forward_check && problem->experiments().size() > 1)
          throw std::invalid_argument("--forward-check: expected one --data-file, got " +
                                      std::to_string(problem->experiments().size()));
        held_out = prediction_problems(*c, *problem, recovery_held_out);
      } catch (const std::exception&) {
        if (!master) return 2;  // rank 0 names the error
        throw;
      }
      use_single_threaded_blas();  // also on MPI workers, which never call run_inference
      if (c->forward_check) {
        ForwardParameters at = o.fixed;
        for (const auto& a : c->at) apply_at(a, at);
        return forward_check(*problem, at, c->trace, c->repeat);
      }
      // SIGINT/SIGTERM: TMCMC stops between chains (calibrate/tmcmc.hpp), laplace-is between
      // gradient evaluations and blocks of draws (calibrate/laplace_is.hpp); the last complete
      // checkpoint stays, main() exits 130/143 (app/interrupt.hpp).
      make_cancellable();
      const ProgressSink progress = stderr_progress(c->quiet || !master, c->verbose);
      const std::string checkpoint = out.empty() ? std::string() : out + "/" + kStageCheckpointName;
      std::optional<SamplerState> resume_state;
      std::optional<LaplaceIsCheckpoint> laplace_is_resume;
      // laplace-is: where its last checkpoint is (the watcher thread of an MPI run reads it).
      std::mutex where_mutex;
      std::string laplace_is_where;
      const auto checkpointing = [&] {
        InferCheckpointing k;
        k.path = checkpoint;
        if (!c->resume.empty()) {
          const std::string what = "--resume " + c->resume;
          // Each sampler continues its own checkpoints only.
          const std::string stored = checkpoint_sampler(checkpoint);
          const std::string wanted = to_string(o.sampler_kind);
          if (stored != wanted)
            throw std::invalid_argument(what + ": the checkpoint is of --sampler " + stored +
                                        ", this run has --sampler " + wanted +
                                        " (expected the sampler of the run it continues)");
          if (o.sampler_kind == SamplerKind::laplace_is) {
            laplace_is_resume = load_laplace_is_checkpoint(checkpoint, *problem, what);
            k.laplace_is_resume = &*laplace_is_resume;
            laplace_is_where = laplace_is_position(laplace_is_resume->state, o.is_samples);
          } else {
            resume_state = load_stage_checkpoint(checkpoint, *problem, what);
            k.resume = &*resume_state;
          }
          remove_stale_checkpoint_temporaries(out);
        }
        k.on_checkpoint = [&](const std::string& where) {
          const std::lock_guard<std::mutex> lock(where_mutex);
          laplace_is_where = where;
        };
        return k;
      };
      std::atomic<bool> told{false};  // the interrupt note was printed
      const auto tell_interrupted = [&] {
        if (told.exchange(true)) return;
        std::string last = "the last complete stage";
        if (o.sampler_kind == SamplerKind::laplace_is) {
          const std::lock_guard<std::mutex> lock(where_mutex);
          last = "the last checkpoint" +
                 (laplace_is_where.empty() ? std::string() : " (" + laplace_is_where + ")");
        }
        std::cerr << "rbc: " << interrupt_name() << " received: stopping"
                  << (checkpoint.empty() || !std::filesystem::exists(checkpoint)
                          ? std::string()
                          : "; " + last + " is in " + checkpoint + ", continue with --resume " +
                                out)
                  << "\n";
      };
      const auto run = [&](const ExecutorFactory& factory) {
        try {
          return run_inference(*problem, progress, factory, checkpointing());
        } catch (const Cancelled&) {
          tell_interrupted();
          throw;
        }
      };
      InferenceResult r;
      if (mpi) {
        MpiSession session;
        if (session.rank() != 0) {
          try {
            mpi_worker_loop(problem->prior(), problem->likelihood());
            // --predict: one more round of forward runs per file, each ended by the master.
            for (const auto& p : held_out) mpi_worker_loop(problem->prior(), p->runner());
            for (const auto& p : recovery_held_out) mpi_worker_loop(problem->prior(), p->runner());
          } catch (const std::exception& e) {
            std::cerr << "rbc: error: MPI rank " << session.rank() << ": " << e.what() << "\n";
            session.abort(1);
          }
          return interrupt_signal() != 0 ? interrupt_exit_code() : 0;
        }
        report(progress, "MPI: " + std::to_string(session.size()) +
                             " ranks (master computes too), one chain per rank at a time");
        // mpirun answers SIGINT/SIGTERM by signalling every rank and killing it about a second
        // later (Open MPI 4.1), maybe before the next poll (a forward run, the outputs): the
        // note is printed as soon as the signal is seen.
        std::atomic<bool> finished{false};
        std::thread watcher([&] {
          const CancelCheck interrupted = interrupt_check();
          while (!finished.load()) {
            if (interrupted()) {
              tell_interrupted();
              return;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
          }
        });
        struct Join {
          std::atomic<bool>& finished;
          std::thread& t;
          ~Join() {
            finished = true;
            t.join();
          }
        } join{finished, watcher};
        // The workers serve the fit, then one round per --predict file; each round ends with
        // mpi_stop_workers(), and on an early exit the rounds left are ended here.
        struct Stop {
          size_t rounds;
          void next() {
            mpi_stop_workers();
            --rounds;
          }
          ~Stop() {
            while (rounds > 0) next();
          }
        } stop{1 + held_out.size() + recovery_held_out.size()};
        r = run([](const InferenceProblem& p) {
          return mpi_master_executor(p.prior(), p.likelihood(), p.options().sampler.cancel);
        });
        r.ranks = session.size();
        stop.next();
        if (r.status == TmcmcStatus::converged && !held_out.empty())
          predictions = predict_all(
              held_out, r, c->predict_draws, progress,
              [](const PredictionProblem& p) {
                return mpi_master_executor(p.fit().prior(), p.runner(),
                                           p.fit().options().sampler.cancel);
              },
              [&stop] { stop.next(); });  // the file's round ends once its results are in
        if (r.status == TmcmcStatus::converged && !recovery_held_out.empty())
          recovery_predictions = predict_all_recovery(
              recovery_held_out, r, c->predict_recovery_draws, progress,
              [](const RecoveryPredictionProblem& p) {
                return mpi_master_executor(p.fit().prior(), p.runner(),
                                           p.fit().options().sampler.cancel);
              },
              [&stop] { stop.next(); });
      } else {
        r = run({});
        if (r.status == TmcmcStatus::converged) {
          predictions = predict_all(held_out, r, c->predict_draws, progress);
          recovery_predictions =
              predict_all_recovery(recovery_held_out, r, c->predict_recovery_draws, progress);
        }
      }
      if (r.status == TmcmcStatus::low_ess) {
        std::cerr << "rbc: error: inference stopped (low_ess): laplace-is kept "
                  << format_number(r.ess) << " effective samples of " << o.is_samples
                  << " (at least " << format_number(o.min_effective_samples)
                  << "): the importance proposal fits this posterior badly; rerun with more "
                     "--is-samples or with --sampler tmcmc\n";
        return 1;
      }
      if (r.status != TmcmcStatus::converged) {
        std::cerr << "rbc: error: inference stopped (" << to_string(r.status)
                  << "): " << r.counts.failed << " of " << r.counts.runs
                  << " forward runs failed (limit 1 %); worst case not converged\n";
        return 1;
      }
      r.command = own_command_line();
      // What made the run (resolved options and provenance, app/run_config.hpp): in summary.json,
      // --json and DIR/run.json, which `rbc infer --config DIR/run.json` repeats.
      r.record = run_record(*cmd);
      // Which parameter combinations the data determine (calibrate/sensitivity.hpp).
      const IdentifiabilityReport identified =
          median_identifiability(*problem, r, candidates, progress);
      if (!out.empty()) {
        write_inference(r, out);
        {  // the report, headed by what made the run (command, config, provenance)
          nlohmann::json report = r.record.is_object() ? r.record : nlohmann::json::object();
          report.update(identified.to_json());
          write_text_atomic(out + "/identifiability.json", report.dump(2) + "\n");
        }
        nlohmann::json run = r.record;
        run["status"] = to_string(r.status);
        run["outputs"] = {"summary.json", "posterior_samples.csv", "posterior_samples.h5",
                          "corner.png", "predictive.png"};
        if (r.experiments.size() > 1)
          for (const auto& e : r.experiments)  // the stretch experiments' fits
            if (!e.axial_q50.empty()) run["outputs"].push_back("predictive_" + e.stem + ".png");
        run["outputs"].push_back(kStageCheckpointName);
        if (!predictions.empty()) {  // --predict
          write_predictions(predictions, out, r.data.name, record_comment_lines(r.record));
          for (const std::string& stem : prediction_file_stems(predictions))
            run["outputs"].push_back(stem + ".png");
        }
        {  // --predict of recovery data
          const std::vector<std::string> stems =
              recovery_prediction_stems(predictions, recovery_predictions);
          for (size_t i = 0; i < recovery_predictions.size(); ++i) {
            write_recovery_prediction(recovery_predictions[i], out, stems[i], r.data.name,
                                      record_comment_lines(r.record));
            run["outputs"].push_back(stems[i] + ".png");
          }
        }
        run["outputs"].push_back("identifiability.json");
        write_text_atomic(out + "/run.json", run.dump(2) + "\n");
      }
      // A signal during the writing (which does not poll): the outputs are complete, the exit
      // status still says the run was interrupted (130/143).
      throw_if_cancelled(interrupt_check());
      if (c->json)
        std::cout << inference_json(r) << "\n";
      else {
        print_summary(r);
        print_predictions(predictions);
        print_recovery_predictions(recovery_predictions);
        for (const auto& line : identified.lines()) std::cout << line << "\n";
      }
      if (!out.empty() && !c->json) {
        std::cout << "outputs: " << out
                  << "/summary.json, run.json, posterior_samples.{csv,h5}, corner.png, "
                     "predictive.png"
                  << ", " << kStageCheckpointName;
        if (r.experiments.size() > 1)
          for (const auto& e : r.experiments)
            if (!e.axial_q50.empty()) std::cout << ", predictive_" << e.stem << ".png";
        for (const std::string& stem : prediction_file_stems(predictions))  // --predict
          std::cout << ", " << stem << ".png";
        for (const std::string& stem : recovery_prediction_stems(predictions, recovery_predictions))
          std::cout << ", " << stem << ".png";
        std::cout << ", identifiability.json\n";
      }
      return 0;
    };
  });
}

}  // namespace rbc::app
