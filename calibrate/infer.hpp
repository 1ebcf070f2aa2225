// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Bayesian calibration of the spectrin parameters from force-diameter data (MODEL.md
// section 7): the library behind `rbc infer` (and the Python binding rbc.infer).
//
// Defaults and why:
// - data: data/suresh2005_healthy_optical_tweezers.csv (Suresh et al. 2005, Fig. 7a/b, healthy
//   cells); sigma = the file's error bars (half the bar extent) with the extra uncertainty the
//   file declares and the one the user adds (--extra-uncertainty, default 0) in quadrature
//   (calibrate/likelihood.hpp);
// - method continuum:2:2000 (p = 2 law, ~2,000 elements): the largest difference of D_A, D_T
//   over the Mills forces against continuum:2:4000 is 0.028 um, below 0.1 x the smallest
//   error bar of the data (0.048 um); 1,000 elements give 0.078 um, 700 give 0.076 um (measured
//   with `rbc stretch --model continuum --order 2 --elements E` at the Mills forces, paper
//   parameters);
// - parameters persistence, lmax, sigma-scale; uniform priors of default_prior()
//   (calibrate/prior_spec.hpp); the parameters not inferred keep the paper's values
//   (p = 7.5 nm, Lmax = 237.75 nm, kappa = 2e-19 J, contact fraction 0.05, sigma scale 1);
// - sampler: laplace-is, the Laplace proposal with adaptive importance correction
//   (calibrate/laplace_is.hpp), 1,000 importance samples in 4 rounds, seed 1: about 1,030
//   forward runs; or (--sampler tmcmc) TMCMC (calibrate/tmcmc.hpp) with 500 samples per stage,
//   target coefficient of variation 1, proposal scale 0.2, 3 Metropolis steps per sample and
//   stage, 4 islands: about 6,000 forward runs. Both give the evidence;
// - the posterior-predictive band is that of the model curve (median and 5-95 % of
//   D_A(F), D_T(F) over the posterior samples), without the measurement noise.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "calibrate/forward_model.hpp"
#include "calibrate/laplace_is.hpp"
#include "calibrate/likelihood.hpp"
#include "calibrate/prior_spec.hpp"
#include "calibrate/recovery_likelihood.hpp"
#include "calibrate/tmcmc.hpp"
#include "compare/methods.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {

struct LaplaceIsCheckpoint;  // calibrate/laplace_is_checkpoint.hpp

/// The posterior sampler of `rbc infer --sampler`: TMCMC (calibrate/tmcmc.hpp) or the Laplace
/// proposal with importance correction (calibrate/laplace_is.hpp; continuum forward model only).
enum class SamplerKind { tmcmc, laplace_is };
/// "tmcmc", "laplace-is".
std::string to_string(SamplerKind s);

/// The extra uncertainty (um) the user adds to one data file's error bars, the file named by
/// its stem (file name without directory and extension): `--extra-uncertainty STEM=UM`.
struct FileExtraUncertainty {
  std::string stem;
  double um = 0;
};

struct InferOptions {
  std::string data_file;  ///< stretch-data CSV; empty = default_data_file()
  /// Several data files, one experiment each, in one posterior (the likelihood is the sum of
  /// theirs; `rbc infer --data-file F1 --data-file F2`). Non-empty: used instead of data_file.
  /// Their stems must differ (they name the per-experiment parameters and outputs).
  std::vector<std::string> data_files;
  /// Per-file extra uncertainties; a file not named gets extra_uncertainty_um.
  std::vector<FileExtraUncertainty> extra_uncertainty_by_file;
  /// Forward-model parameters inferred once per experiment (each also in `parameters`), e.g.
  /// contact-fraction: the slot of experiment e is named "contact-fraction[STEM]" and has the
  /// parameter's prior box; the forward run of experiment e uses its own value.
  std::vector<Parameter> per_experiment;
  /// Recovery-curve data files (DataKind::recovery, e.g. data/hochmuth1979_recovery_cells.csv):
  /// the release scene and the likelihood's nuisance handling (calibrate/recovery_likelihood.hpp).
  /// Such a file needs eta-m in `parameters`.
  RecoveryModelOptions recovery_model;
  RecoveryLikelihoodOptions recovery_likelihood;
  Method method{MethodKind::continuum, 2000, WlcExpansion::order2};
  std::vector<Parameter> parameters = {Parameter::persistence, Parameter::lmax,
                                       Parameter::sigma_scale};
  std::vector<PriorRange> priors;  ///< overrides of default_prior(), one per parameter at most
  /// Extra uncertainty (um) the user adds in quadrature to every error bar, on top of what the
  /// data file declares (calibrate/likelihood.hpp); 0: the file's sigmas as they are.
  double extra_uncertainty_um = 0;
  ForwardParameters fixed;       ///< values of the physical parameters not inferred
  double fixed_sigma_scale = 1;  ///< when sigma-scale is not inferred
  TmcmcOptions sampler = default_sampler();
  /// Which sampler; laplace-is uses sampler.seed, is_samples and is_rounds, not the TMCMC
  /// settings. Default laplace-is: on both stretch tables it uses about a sixth of TMCMC's
  /// forward runs for the same medians and 90 % intervals (`rbc bench infer` runs both side by
  /// side; docs/validation/calibration.md gives the figures). TMCMC needs no gradient and stays
  /// the reference (`--sampler tmcmc`).
  SamplerKind sampler_kind = SamplerKind::laplace_is;
  /// Importance samples of laplace-is (forward runs after the mode search).
  int is_samples = 1000;
  /// laplace-is: adaptation rounds of the importance proposal (LaplaceIsOptions::rounds), 1 to
  /// is_samples; 1: the Laplace proposal alone. With 4 rounds of 250 the Mills 2004 table keeps
  /// 430-510 effective samples of 1,000, where the Laplace proposal alone keeps 39 (its
  /// persistence-Lmax ridge is curved).
  int is_rounds = 4;
  /// laplace-is: fewest effective samples (sum w)^2 / sum w^2 of an accepted posterior (>= 0);
  /// below it the run ends with status low_ess. At the default 50 the ends of a 90 % interval
  /// rest on 2.5 effective samples each.
  double min_effective_samples = 50;
  int threads = 0;  ///< OpenMP threads for the forward runs (0: OpenMP's default)
  /// Newton force tolerance of the continuum forward runs (pN; ForwardOptions documents
  /// the default 1e-4 pN).
  double force_tolerance_pN = ForwardOptions::default_newton().force_tolerance_pN;
  /// Continuum forward runs on the mirror-symmetric states (NewtonOptions::symmetry).
  Symmetry symmetry = ForwardOptions::default_newton().symmetry;
  /// Throws std::invalid_argument naming the value: repeated parameters, a prior for a
  /// parameter not inferred or given twice, an invalid prior box, extra uncertainty < 0,
  /// invalid sampler options or fixed parameters. Does not read the data file.
  void validate() const;
  static TmcmcOptions default_sampler() {
    TmcmcOptions t;
    t.samples = 500;
    t.chain_length = 3;
    return t;
  }
  /// The smallest --samples the sampler accepts (5 per island, TmcmcOptions::islands).
  static int minimum_samples() { return 5 * default_sampler().islands; }
  /// default_data_directory()/suresh2005_healthy_optical_tweezers.csv.
  static std::string default_data_file();
  /// The data file actually used (the first of data_paths()).
  std::string data_path() const;
  /// Every data file, in the order given (data_files, else {data_path of data_file}).
  std::vector<std::string> data_paths() const;
  /// The added extra uncertainty (um) of the data file with this stem.
  double extra_uncertainty_for(const std::string& stem) const;
  /// The prior box of each inferred parameter (overrides applied), in parameter order.
  std::vector<PriorRange> prior_ranges() const;
};

/// One experiment (data file) of an inference.
struct Experiment {
  DataKind kind = DataKind::stretch;
  std::string path;                              ///< as given
  std::string stem;                              ///< file name without directory and extension
  DiameterData data;                             ///< stretch data (empty for recovery data)
  std::shared_ptr<const RecoveryData> recovery;  ///< recovery data (null for stretch data)
  /// Its forward-run group (InferenceProblem::forward(group); -1 for recovery data, which runs
  /// the release scene instead) and the index of each of its forces among the group's forces.
  int group = 0;
  std::vector<int> force_index;
};

/// One coordinate of theta: a parameter, shared (experiment -1) or one experiment's own.
struct ParameterSlot {
  Parameter parameter = Parameter::persistence;
  int experiment = -1;
  std::string name;  ///< to_string(parameter), or "NAME[STEM]" for an experiment's own
};

/// The stem of a data file's path: its file name without directory and extension.
std::string data_file_stem(const std::string& path);

/// A prepared problem: data loaded and checked, forward model built, prior box. Every MPI
/// rank builds the same one from the same options.
///
/// Several experiments: the forward runs are grouped so that one run serves every experiment
/// whose forward parameters coincide. Without per-experiment parameters there is one group,
/// over the union of the experiments' forces (a force two files share is solved once per
/// theta); with them, one group per experiment. A warm state is the groups' states one after
/// the other.
class InferenceProblem {
 public:
  /// Throws std::invalid_argument / std::runtime_error naming the value for bad options or
  /// a bad data file, before any forward run.
  explicit InferenceProblem(const InferOptions& options);
  ~InferenceProblem();
  const InferOptions& options() const { return options_; }
  /// The first experiment's data (the only one's, for one data file).
  const DiameterData& data() const { return data_; }
  const std::vector<Experiment>& experiments() const { return experiments_; }
  /// theta's coordinates (the parameters in options' order, a per-experiment one expanded
  /// into one slot per experiment).
  const std::vector<ParameterSlot>& slots() const { return slots_; }
  std::vector<std::string> names() const;
  std::vector<std::string> units() const;
  const PriorBox& prior() const { return prior_; }
  const Likelihood& likelihood() const { return *likelihood_; }
  /// The first group's forward model (the only one for one data file).
  const ForwardModel& forward() const { return *forwards_.front(); }
  int groups() const { return static_cast<int>(forwards_.size()); }
  const ForwardModel& forward(int group) const { return *forwards_[group]; }
  /// Values of a warm state per group: forces x (3N + 2); their sum is a whole state's size.
  size_t group_state_size(int group) const;
  size_t state_size() const;
  /// Parameters of a sample theta (natural units) for the first experiment.
  ForwardParameters physical(std::span<const double> theta) const;
  /// The same for experiment e (its own slots where it has them).
  ForwardParameters physical(std::span<const double> theta, int experiment) const;
  /// For forward-run group g (its first experiment's).
  ForwardParameters group_physical(std::span<const double> theta, int group) const;
  double sigma_scale(std::span<const double> theta) const;
  /// The between-experiment sd tau (um) of the hierarchical layer; 0 when not inferred.
  double tau(std::span<const double> theta) const;
  /// The membrane viscosity eta_m (pN s/um) of recovery data; 0 when not inferred.
  double eta_m(std::span<const double> theta) const;
  /// The between-cell sd of log eta_m (calibrate/recovery_likelihood.hpp, cells with their own
  /// viscosity); 0 when not inferred (every cell at eta_m).
  double eta_spread(std::span<const double> theta) const;
  /// The release scene of the recovery experiments; null without recovery data.
  const RecoveryModel* recovery_model() const { return recovery_model_.get(); }
  bool has_recovery() const { return recovery_model_ != nullptr; }
  /// log L of recovery experiment e at theta (a release-scene trajectory, rescaled in time to
  /// eta_m; with eta-spread inferred, each cell integrated over its own viscosity,
  /// recovery_spread_log_likelihood); -inf when the trajectory or the nuisance fit fails.
  double recovery_log_likelihood(std::span<const double> theta, int experiment) const;
  /// Model diameters at the first group's forces from a sample's warm state.
  ModelDiameters diameters_from_state(const WarmState& state) const;
  /// Model diameters at experiment e's forces from a sample's (whole) warm state.
  ModelDiameters experiment_diameters(const WarmState& state, int experiment) const;
  /// Experiment e's model diameters picked from its group's diameters.
  ModelDiameters experiment_diameters(const std::vector<ModelDiameters>& group_diameters,
                                      int experiment) const;
  /// log L of the stretch experiments at theta from the groups' model diameters: the sum over
  /// them of gaussian_log_likelihood(data, model, sigma scale, tau).
  double log_likelihood(std::span<const double> theta,
                        const std::vector<ModelDiameters>& group_diameters) const;
  /// log L of experiment e alone from its model diameters.
  double experiment_log_likelihood(std::span<const double> theta, int experiment,
                                   const ModelDiameters& model) const;

 private:
  InferOptions options_;
  DiameterData data_;
  std::vector<Experiment> experiments_;
  std::vector<ParameterSlot> slots_;
  PriorBox prior_;
  std::vector<std::unique_ptr<ForwardModel>> forwards_;
  std::unique_ptr<RecoveryModel> recovery_model_;
  std::unique_ptr<Likelihood> likelihood_;
};

/// mean, sd, 5/50/95 % quantiles (linear interpolation between order statistics).
struct Summary {
  std::string name, unit;
  double mean = 0, sd = 0, q05 = 0, q50 = 0, q95 = 0;
};
Summary summarise(const std::string& name, const std::string& unit, const Eigen::VectorXd& v);
/// The same for weighted samples (weights w summing to 1; weighted_quantile).
Summary summarise_weighted(const std::string& name, const std::string& unit,
                           const Eigen::VectorXd& v, const Eigen::VectorXd& w);

/// Shear and area moduli (uN/m) in closed form (homogenise/moduli.hpp) at a sample's
/// persistence length and Lmax.
LinearModuli sample_moduli(const ForwardParameters& p);

struct InferenceResult {
  TmcmcStatus status = TmcmcStatus::converged;
  std::vector<std::string> names, units;    ///< inferred parameters
  Eigen::MatrixXd samples;                  ///< samples x parameters, natural units
  Eigen::VectorXd log_likelihood;           ///< per sample
  Eigen::VectorXd mu_uN_per_m, K_uN_per_m;  ///< derived, per sample
  std::vector<Summary> parameters;          ///< per inferred parameter
  Summary mu, K;                            ///< derived moduli
  double log_evidence = 0, log_evidence_sd = 0;
  ForwardCounts counts;
  std::vector<StageInfo> stages;
  double wall_s = 0;
  // Posterior predictive (model curve, no noise) at the data's forces.
  DiameterData data;
  std::vector<double> axial_q05, axial_q50, axial_q95, transverse_q05, transverse_q50,
      transverse_q95;
  std::string method, data_file;  ///< data: `data` holds its name and extra uncertainties
  std::string command;  ///< the command line that made it (set by the caller; summary.json)
  /// What made it, set by the caller (the CLI's run record: "config", the resolved options,
  /// and "provenance"); its keys are copied into summary.json. Null: none.
  nlohmann::json record;
  std::vector<double> prior_lower, prior_upper;  ///< prior box per inferred parameter
  int vertices = 0, elements = 0, samples_per_stage = 0, threads = 0, ranks = 1;
  std::uint64_t seed = 0;
  int resumed_from_stage = -1;
  std::string sampler = "tmcmc";  ///< to_string(SamplerKind) of the sampler that made it
  /// laplace-is: effective sample size of the importance weights, (sum w)^2 / sum w^2; the
  /// mode (natural units), Newton steps, gradient evaluations (forward run + sensitivities).
  double ess = 0;
  int is_rounds = 0;              ///< laplace-is: adaptation rounds (LaplaceIsOptions::rounds)
  std::vector<double> round_ess;  ///< laplace-is: ESS after each round but the last
  std::vector<double> mode;
  int newton_steps = 0;
  long long gradient_evaluations =
      0;  ///< the checkpoint's stage a resumed run started from; -1: none
  /// Held-out predictions (calibrate/predictive.hpp, predictions_json), set by the caller;
  /// summary.json's "predictions". Null: none.
  nlohmann::json predictions;
  /// Per experiment (every data file, in order): its data, file, content digest and the
  /// posterior-predictive model band at its forces (the first is `data` and the fields above).
  struct ExperimentFit {
    std::string path, stem, kind, digest;
    DiameterData data;
    std::vector<double> axial_q05, axial_q50, axial_q95, transverse_q05, transverse_q50,
        transverse_q95;
  };
  std::vector<ExperimentFit> experiments;
};

/// Makes the executor for a problem (e.g. calibrate/mpi_executor.hpp's master); empty =
/// omp_executor with options.threads.
using ExecutorFactory = std::function<Executor(const InferenceProblem&)>;

/// Runs the inference. Progress (stage, exponent, acceptance, forward runs, elapsed) goes
/// to `progress`. Returns the result with status failed_runs when more than 1 % of the
/// forward runs failed (the caller exits 1).
InferenceResult run_inference(const InferenceProblem& problem, const ProgressSink& progress = {},
                              const ExecutorFactory& executor = {});
/// Stage checkpoints of a run (calibrate/stage_checkpoint.hpp).
struct InferCheckpointing {
  /// Written atomically after every completed stage (stage 0 included); empty: none.
  std::string path;
  /// Continue from this state (load_stage_checkpoint) instead of starting from the prior.
  const SamplerState* resume = nullptr;
  /// --sampler laplace-is: continue from this checkpoint (calibrate/laplace_is_checkpoint.hpp,
  /// load_laplace_is_checkpoint) instead of starting anew; `path` receives its checkpoints.
  const LaplaceIsCheckpoint* laplace_is_resume = nullptr;
  /// --sampler laplace-is: called after every checkpoint write with where the run is
  /// (laplace_is_position). May be empty.
  std::function<void(const std::string&)> on_checkpoint;
};
/// The same, writing and/or continuing from stage checkpoints. A run continued from a
/// checkpoint of the same problem gives the straight run's result, bit for bit, apart from
/// the timing fields (wall_s, stages' elapsed_s, threads, ranks, resumed_from_stage). Polls
/// options().sampler.cancel between stages and, with the default executor, between chains.
InferenceResult run_inference(const InferenceProblem& problem, const ProgressSink& progress,
                              const ExecutorFactory& executor,
                              const InferCheckpointing& checkpointing);
/// laplace-is on the problem (calibrate/laplace_is_infer.cpp): the mode search with the
/// likelihood gradient and Gauss-Newton information from the sensitivities, then
/// options().is_samples evaluations through `executor`. Counts the mode search's forward runs
/// and sensitivity solves when the pointers are given.
LaplaceIsResult run_problem_laplace_is(const InferenceProblem& problem, const Executor& executor,
                                       const ProgressSink& progress,
                                       long long* forward_runs = nullptr,
                                       long long* sensitivity_solves = nullptr);
/// The same, writing checkpoints to checkpointing.path (when set) and continuing from
/// checkpointing.laplace_is_resume (when set); polls options().sampler.cancel between gradient
/// evaluations and blocks of importance draws (rbc::Cancelled).
LaplaceIsResult run_problem_laplace_is(const InferenceProblem& problem, const Executor& executor,
                                       const ProgressSink& progress,
                                       const InferCheckpointing& checkpointing,
                                       long long* forward_runs = nullptr,
                                       long long* sensitivity_solves = nullptr);
/// Convenience: builds the problem and runs it.
InferenceResult run_inference(const InferOptions& options, const ProgressSink& progress = {});

/// Which sigma the likelihood used for a data set, one line: "the file's error bars" or
/// "the file's error bars (+) 0.1 um declared (+) 0.2 um added (extra 0.2236 um), in
/// quadrature".
std::string sigma_text(const DiameterData& data);

/// JSON summary (the fields of `rbc infer --json`).
std::string inference_json(const InferenceResult& r);

/// Writes DIR/summary.json, posterior_samples.{csv,h5}, corner.{png,gp} with its CSVs,
/// predictive.{png,gp} (Fig. 7: median and 90 % band against the data) with its CSV.
/// Every file is written atomically (temporary name, then rename).
void write_inference(const InferenceResult& r, const std::string& dir);

}  // namespace rbc
