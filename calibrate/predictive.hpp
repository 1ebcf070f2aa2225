// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Prediction of held-out data (`rbc infer --predict FILE`): the posterior predictive of a
// stretch-data set that the fit did not use, at that set's own forces, checked against it.
//
// For each force F_k of the held-out file and each diameter (D_A, D_T), the predictive
// distribution is the posterior mixture
//   p(y_k | fit data) = sum_j w_j N(y_k; D(F_k; theta_j), (c_j s_k)^2),
// theta_j the posterior draws (weights w_j: TMCMC's final samples are equally weighted, so
// w_j = multiplicity of the draw), D the forward model at the draw's physical parameters, s_k
// the held-out point's sigma exactly as the likelihood would build it for that file
// (calibrate/likelihood.hpp: its error bar, its declared extra uncertainty and the user's
// --extra-uncertainty in quadrature) and c_j the draw's sigma-scale (the inferred value when
// sigma-scale is inferred, else the fixed one, 1 by default): the noise model the fit assumed,
// applied to the held-out file's own error bars. The quantiles are those of the mixture itself
// (mixture_quantile: its CDF is a weighted sum of normal CDFs, inverted by bisection), i.e. the
// limit of infinitely many noise draws per posterior draw: no Monte Carlo noise on top of the
// posterior draws'.
//
// Draws: with `draws` >= the number of posterior samples (or 0), every sample once; otherwise
// `draws` samples by systematic resampling (predictive_draws) with the run's seed. The forward
// model runs once per distinct set of physical parameters among the draws (TMCMC's population
// repeats points whose chains rejected every proposal), cold (from the rest shape) at the
// held-out forces, through the sampler's Executor (OpenMP threads or the MPI master-worker pool):
// each run depends on its parameters only, so the prediction is the same on any thread or rank
// count. A draw whose forward run fails is left out and counted.
//
// Coverage: the fraction of the file's points inside the central 50 % band [q25, q75] and the
// central 90 % band [q05, q95] of their predictive distribution, for D_A and D_T apart and
// together. The 0 pN point counts once, as a D_A point (the likelihood's rule: one measured
// diameter of the unstretched cell).
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "calibrate/infer.hpp"

namespace rbc {

/// The q-quantile (0 < q < 1) of the mixture sum_i w_i N(mean_i, sd_i^2) / sum_i w_i: the
/// smallest x with F(x) >= q, to a relative tolerance of ~1e-12 of the components' spread. A
/// component with sd 0 is a point mass, so with every sd 0 this is the weighted sample's
/// quantile (inverse of its step CDF). Weights >= 0 and not all 0, sds >= 0, sizes equal;
/// throws std::invalid_argument naming what is wrong otherwise.
double mixture_quantile(std::span<const double> mean, std::span<const double> sd,
                        std::span<const double> weight, double q);

/// `draws` (> 0) indices into a sample of weights (>= 0, not all 0) by systematic resampling
/// with one uniform offset from std::mt19937_64 seeded by stream_seed(seed, 0, 0, 4)
/// (calibrate/tmcmc.hpp; purpose 4 is no stream of the sampler's): sample i appears
/// floor(draws w_i / W) or that plus one times. Increasing order. With equal weights and
/// draws = size every index appears once.
std::vector<int> predictive_draws(std::span<const double> weight, int draws, std::uint64_t seed);

/// Posterior predictive bands at one file's forces (um): quantiles 5, 25, 50, 75, 95 %.
struct PredictiveBand {
  std::vector<double> q05, q25, q50, q75, q95;
};

/// Points inside the central 50 % and 90 % bands, D_A and D_T apart (D_T without the 0 pN
/// point).
struct PredictiveCoverage {
  int axial_points = 0, transverse_points = 0;
  int axial_in_50 = 0, axial_in_90 = 0, transverse_in_50 = 0, transverse_in_90 = 0;
  int points() const { return axial_points + transverse_points; }
  double fraction_50() const;
  double fraction_90() const;
};

/// Counts the points of `data` inside the bands.
PredictiveCoverage predictive_coverage(const DiameterData& data, const PredictiveBand& axial,
                                       const PredictiveBand& transverse);

/// The held-out prediction of one file.
struct HeldOutPrediction {
  std::string path;
  DiameterData data;  ///< the held-out data with the sigmas of its likelihood
  PredictiveBand axial, transverse;
  PredictiveCoverage coverage;
  int draws = 0;                 ///< posterior draws used (failed ones included)
  int forward_runs = 0;          ///< distinct physical parameters among them, one run each
  int failed_runs = 0;           ///< forward runs that failed (their draws are left out)
  bool sigma_scaled = false;     ///< sigma-scale is inferred: each draw scales the sigmas
  double fixed_sigma_scale = 1;  ///< the scale when it is not inferred
  double wall_s = 0;
};

/// A held-out data file prepared for prediction from a fit's problem: the data loaded with the
/// rules of the fit's likelihood (load_diameter_data with the fit's added extra uncertainty and
/// method) and a forward model at its forces with the fit's forward settings. Every MPI rank
/// builds the same one.
class PredictionProblem {
 public:
  /// Throws std::invalid_argument / std::runtime_error naming the file for a missing or bad
  /// file, a force beyond the method's range, or the fit's own data file; solves nothing.
  PredictionProblem(const InferenceProblem& fit, const std::string& path);
  ~PredictionProblem();
  const std::string& path() const { return path_; }
  const DiameterData& data() const { return data_; }
  const InferenceProblem& fit() const { return fit_; }
  /// The forward runs as a "likelihood" for the sampler's executors: evaluate(theta) runs the
  /// forward model at problem.physical(theta) from the rest shape, returns log L = 0 (failed:
  /// -infinity) and puts D_A at every force, then D_T at every force (um), in *state_out.
  const Likelihood& runner() const { return *runner_; }

 private:
  const InferenceProblem& fit_;
  std::string path_;
  DiameterData data_;
  std::unique_ptr<ForwardModel> forward_;
  std::unique_ptr<Likelihood> runner_;
};

/// Predicts the held-out file from a fit's posterior samples (`draws`: 0 = all; the fit's
/// seed). `executor` runs the forward runs (empty: OpenMP threads as the fit's options say,
/// polling its cancel check; rbc::Cancelled propagates). Progress goes to `progress`.
HeldOutPrediction predict_held_out(const PredictionProblem& problem, const InferenceResult& fit,
                                   int draws, const Executor& executor = {},
                                   const ProgressSink& progress = {});

/// The noise rule of a prediction in words: sigma_text of its data, and "; times each draw's
/// sigma-scale" when sigma-scale is inferred (a fixed scale other than 1 by its value).
std::string prediction_sigma_text(const HeldOutPrediction& p);

/// The default of `rbc infer --predict-draws`: 200 draws of the fit's samples (500 by default).
/// Measured on the default calibration of the Suresh 2005 table predicting the Mills 2004 Fig. 8
/// table (continuum:2:2000, 13 forces, cold runs): every sample (495 distinct forward runs) took
/// 2.4x the CPU time of 200 draws (44.5 s against 18.5 s), and moved no quantile by more than
/// 0.06 um, under 3 % of the narrowest 90 % band (2.17 um).
constexpr int kDefaultPredictiveDraws = 200;

/// The "predictions" entry of summary.json and --json: one object per prediction with the
/// file's name, path, sigma rule, draws, per force the quantiles and the observed values, and
/// the coverage of the 50 % and 90 % bands.
nlohmann::json predictions_json(const std::vector<HeldOutPrediction>& predictions);

/// Output names of the i-th prediction of a list (predict_<file stem>, made unique).
std::vector<std::string> prediction_file_stems(const std::vector<HeldOutPrediction>& predictions);
/// The same from the predicted files' paths (stretch and recovery files alike).
std::vector<std::string> prediction_file_stems(const std::vector<std::string>& paths);

/// Writes DIR/STEM.csv (bands, data and sigmas; `comments` first, e.g. the run record) and
/// DIR/STEM.{gp,png} (the held-out data with their error bars over the 50 % and 90 % predictive
/// bands of D_A and D_T), atomically, for each prediction; STEM from prediction_file_stems.
void write_predictions(const std::vector<HeldOutPrediction>& predictions, const std::string& dir,
                       const std::string& fit_label, const std::vector<std::string>& comments = {});

}  // namespace rbc
