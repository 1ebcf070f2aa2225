// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Prediction of held-out shape-recovery data (`rbc infer --predict CELLS.csv`, the format of
// data/hochmuth1979_recovery_cells.csv): the posterior predictive of every cell's length over
// width lambda(t) at the file's own times, checked against it.
//
// Per posterior draw j (predictive_draws of calibrate/predictive.hpp, the run's seed): one
// release-scene trajectory (calibrate/recovery_likelihood.hpp; the draw's p, Lmax, kappa and
// contact fraction, the fit's release-scene options) gives the decay g_j at eta_ref; the draw's
// membrane viscosity eta_m,j is the inferred one when eta-m is a fitted parameter, otherwise a
// uniform draw on eta-m's prior box (default_prior: 0.2 to 2 pN s/um) from its own random
// stream (stream_seed(seed, 0, j, 5)), since stretch data determine the shear modulus mu but not
// eta_m. Data time t reads g_j at reference time t eta_ref/eta_m,j (the likelihood's rescaling).
// With eta-spread inferred (cells with their own viscosity, calibrate/recovery_likelihood.hpp),
// each cell c of the held-out file is a new cell at draw j: its viscosity eta_m,j exp(s_j eps)
// with eps ~ N(0, 1) from its own stream (stream_seed(seed, c + 1, j, 6), Box-Muller).
// Each cell's nuisances (lambda_0, lambda_inf) are those of the likelihood at that draw: the
// mode of its fit to the cell's own readings (evaluate_recovery_likelihood), so the prediction
// is of the curve's shape in time, not of its amplitude or limit. The predictive of a reading at
// time t is the mixture over the draws of N(lambda_inf (1 + r0 g)/(1 - r0 g), sigma_ratio^2)
// (the file's reading noise), its quantiles those of the mixture (mixture_quantile).
//
// The normalised recovery (lambda - L)/(lambda + L) with L the cell's median over the draws of
// lambda_inf is a monotone map of lambda, so its quantiles are the map of lambda's and the
// coverage is the same in either; the plot and the CSV show it.
//
// The trajectories run once per distinct set of physical parameters among the draws, through
// the sampler's Executor (OpenMP threads or the MPI master-worker pool), each from its
// parameters alone: the prediction is the same on any thread or rank count.
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calibrate/infer.hpp"
#include "calibrate/recovery_likelihood.hpp"

namespace rbc {

/// The default of `rbc infer --predict-recovery-draws`: 100 posterior draws, one release
/// trajectory each (1.35 CPU s at the default 1,000 elements: about 70 s on two threads), where
/// a stretch file's 200 draws (kDefaultPredictiveDraws) cost about 0.1 CPU s each.
constexpr int kDefaultRecoveryPredictiveDraws = 100;

/// One cell's predictive bands (length over width) and coverage.
struct RecoveryCellPrediction {
  int id = 0;
  std::vector<double> time_s, observed;         ///< the cell's readings (lambda)
  std::vector<double> q05, q25, q50, q75, q95;  ///< predictive quantiles of lambda
  /// The normalisation L of the normalised recovery (lambda - L)/(lambda + L): the median over
  /// the draws of the cell's lambda_inf mode; and the median of its lambda_0 mode.
  double lambda_inf = 1, lambda_0 = 1;
  int in_50 = 0, in_90 = 0;  ///< readings inside [q25, q75], [q05, q95]
  int points() const { return static_cast<int>(time_s.size()); }
  /// (lambda - lambda_inf)/(lambda + lambda_inf).
  double normalised(double lambda) const { return (lambda - lambda_inf) / (lambda + lambda_inf); }
};

/// The held-out prediction of one recovery file.
struct RecoveryPrediction {
  std::string path;
  RecoveryData data;
  std::vector<RecoveryCellPrediction> cells;
  int draws = 0;         ///< posterior draws (failed ones included)
  int trajectories = 0;  ///< distinct physical parameters among them, one release run each
  int failed_runs = 0;   ///< trajectories that failed (their draws are left out)
  int failed_fits = 0;   ///< draws left out because a cell's nuisance fit failed
  int used_draws = 0;    ///< draws in the bands
  bool eta_m_inferred = false;
  bool eta_spread_inferred = false;  ///< each cell at its own viscosity (eta-spread inferred)
  double eta_m_lower = 0, eta_m_upper = 0;  ///< the prior box eta_m is drawn from otherwise
  int elements = 0;                         ///< continuum triangles of the release scene
  /// Kelvin-Voigt time t_c = eta_m/mu over the used draws (s): 5, 50, 95 % quantiles.
  double tc_q05_s = 0, tc_q50_s = 0, tc_q95_s = 0;
  /// eta_m over the used draws (pN s/um): 5, 50, 95 % quantiles.
  double eta_m_q05 = 0, eta_m_q50 = 0, eta_m_q95 = 0;
  double wall_s = 0;
  int points() const;
  int in_50() const;
  int in_90() const;
  double fraction_50() const;
  double fraction_90() const;
  /// How eta_m enters, in words: "eta_m inferred: each draw's own", the same followed by
  /// ", each cell at eta_m exp(s eps), eps ~ N(0,1)" with eta-spread, or "eta_m not inferred:
  /// drawn from its prior 0.2 to 2 pN s/um".
  std::string eta_m_text() const;
};

/// A held-out recovery file prepared for prediction from a fit's problem: the data read
/// (read_recovery_data) and the release scene with the fit's options (InferOptions::
/// recovery_model). Every MPI rank builds the same one.
class RecoveryPredictionProblem {
 public:
  /// Throws std::invalid_argument / rbc::InvalidParameter naming the file for a missing or bad
  /// file or one of the fit's own data files; simulates nothing.
  RecoveryPredictionProblem(const InferenceProblem& fit, const std::string& path);
  ~RecoveryPredictionProblem();
  const std::string& path() const { return path_; }
  const RecoveryData& data() const { return data_; }
  const InferenceProblem& fit() const { return fit_; }
  const RecoveryModel& model() const { return *model_; }
  /// The trajectories as a "likelihood" for the sampler's executors: evaluate(theta) runs the
  /// release scene at fit().physical(theta), returns log L = 0 (failed: -infinity) and puts the
  /// curve in *state_out (encode: recovery_curve_state).
  const Likelihood& runner() const { return *runner_; }

 private:
  const InferenceProblem& fit_;
  std::string path_;
  RecoveryData data_;
  std::unique_ptr<RecoveryModel> model_;
  std::unique_ptr<Likelihood> runner_;
};

/// A converged curve as a flat vector (the executors' state) and back.
std::vector<double> recovery_curve_state(const RecoveryCurve& curve);
RecoveryCurve recovery_curve_from_state(const std::vector<double>& state);

/// Predicts the held-out recovery file from a fit's posterior samples (`draws`: 0 = every
/// sample; the fit's seed). `executor` runs the trajectories (empty: OpenMP threads as the fit's
/// options say, polling its cancel check; rbc::Cancelled propagates). Throws std::runtime_error
/// when no draw gives a band.
RecoveryPrediction predict_recovery(const RecoveryPredictionProblem& problem,
                                    const InferenceResult& fit, int draws,
                                    const Executor& executor = {},
                                    const ProgressSink& progress = {});

/// The "predictions" entry of one recovery prediction: kind "recovery", per cell the times,
/// readings, lambda quantiles and normalised ones, coverage per cell and overall, eta_m's rule.
nlohmann::json recovery_prediction_json(const RecoveryPrediction& p);

/// Writes DIR/STEM.csv (per reading: cell, time, lambda quantiles and reading, the normalised
/// ones; `comments` first), DIR/STEM_cellN.csv (one per cell, for the plot) and DIR/STEM.{gp,png}
/// (each cell's normalised readings over its 50 % and 90 % bands against time), atomically.
void write_recovery_prediction(const RecoveryPrediction& p, const std::string& dir,
                               const std::string& stem, const std::string& fit_label,
                               const std::vector<std::string>& comments = {});

}  // namespace rbc
