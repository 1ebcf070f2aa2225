// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/recovery_prediction.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>

#include "calibrate/predictive.hpp"
#include "compare/plot.hpp"
#include "core/blas_threads.hpp"
#include "core/io.hpp"

namespace rbc {

namespace {
namespace fs = std::filesystem;
constexpr double kUnboundedLogL = std::numeric_limits<double>::infinity();
/// stream_seed's purpose of the eta_m draws from the prior (4 is the predictive draws').
constexpr int kEtaDrawPurpose = 5;
/// stream_seed's purpose of a held-out cell's own viscosity (eta-spread inferred).
constexpr int kCellEtaPurpose = 6;

/// A standard normal from its own stream (Box-Muller on two portable uniforms in (0, 1]).
double cell_normal(std::uint64_t seed, int cell, int draw) {
  std::mt19937_64 gen(stream_seed(seed, cell + 1, draw, kCellEtaPurpose));
  const double u1 = (static_cast<double>(gen() >> 11) + 1) * 0x1.0p-53;
  const double u2 = static_cast<double>(gen() >> 11) * 0x1.0p-53;
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * std::numbers::pi * u2);
}

/// Release trajectories in the Likelihood shape the executors run.
class RecoveryRunner final : public Likelihood {
 public:
  RecoveryRunner(const InferenceProblem& fit, const RecoveryModel& model)
      : fit_(fit), model_(model) {}
  int dimension() const override { return fit_.prior().dimension(); }
  LikelihoodValue evaluate(std::span<const double> theta, const WarmState&,
                           WarmState* state_out) const override {
    const RecoveryCurve curve = model_.simulate(fit_.physical(theta));
    LikelihoodValue v;
    v.retried = curve.halved_steps > 0;
    if (!curve.converged) {
      v.failed = true;
      v.log_likelihood = -kUnboundedLogL;
      return v;
    }
    if (state_out) *state_out = recovery_curve_state(curve);
    return v;
  }

 private:
  const InferenceProblem& fit_;
  const RecoveryModel& model_;
};

std::string number_text(double v, int digits = 6) {
  std::ostringstream s;
  s << std::setprecision(digits) << v;
  return s.str();
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
}  // namespace

int RecoveryPrediction::points() const {
  int n = 0;
  for (const auto& c : cells) n += c.points();
  return n;
}
int RecoveryPrediction::in_50() const {
  int n = 0;
  for (const auto& c : cells) n += c.in_50;
  return n;
}
int RecoveryPrediction::in_90() const {
  int n = 0;
  for (const auto& c : cells) n += c.in_90;
  return n;
}
double RecoveryPrediction::fraction_50() const {
  return points() ? static_cast<double>(in_50()) / points() : 0.0;
}
double RecoveryPrediction::fraction_90() const {
  return points() ? static_cast<double>(in_90()) / points() : 0.0;
}
std::string RecoveryPrediction::eta_m_text() const {
  if (eta_m_inferred && eta_spread_inferred)
    return "eta_m inferred: each draw's own, each cell at eta_m exp(s eps), eps ~ N(0,1)";
  if (eta_m_inferred) return "eta_m inferred: each draw's own";
  return "eta_m not inferred: drawn from its prior " + number_text(eta_m_lower) + " to " +
         number_text(eta_m_upper) + " pN s/um";
}

std::vector<double> recovery_curve_state(const RecoveryCurve& c) {
  std::vector<double> s = {c.shear_modulus_pN_per_um, c.eta_ref_pN_s_per_um, c.lambda_inf,
                           static_cast<double>(c.halved_steps),
                           static_cast<double>(c.time_s.size())};
  s.insert(s.end(), c.time_s.begin(), c.time_s.end());
  s.insert(s.end(), c.shape.begin(), c.shape.end());
  s.insert(s.end(), c.lambda.begin(), c.lambda.end());
  return s;
}

RecoveryCurve recovery_curve_from_state(const std::vector<double>& s) {
  RecoveryCurve c;
  if (s.size() < 5) throw std::invalid_argument("recovery curve state: too short");
  const size_t n = static_cast<size_t>(s[4]);
  if (s.size() != 5 + 3 * n)
    throw std::invalid_argument("recovery curve state: " + std::to_string(s.size()) +
                                " values, expected " + std::to_string(5 + 3 * n));
  c.shear_modulus_pN_per_um = s[0];
  c.eta_ref_pN_s_per_um = s[1];
  c.lambda_inf = s[2];
  c.halved_steps = static_cast<int>(s[3]);
  c.time_s.assign(s.begin() + 5, s.begin() + 5 + n);
  c.shape.assign(s.begin() + 5 + n, s.begin() + 5 + 2 * n);
  c.lambda.assign(s.begin() + 5 + 2 * n, s.end());
  c.converged = true;
  c.status = "converged";
  return c;
}

RecoveryPredictionProblem::RecoveryPredictionProblem(const InferenceProblem& fit,
                                                     const std::string& path)
    : fit_(fit), path_(path) {
  const InferOptions& o = fit.options();
  std::error_code ec;
  for (const std::string& fitted : o.data_paths())
    if (fs::equivalent(path, fitted, ec))
      throw std::invalid_argument("--predict " + path +
                                  (o.data_paths().size() > 1
                                       ? ": one of the fit's data files"
                                       : ": the data file of the fit itself") +
                                  "; expected a data set the fit did not use");
  data_ = read_recovery_data(path);
  model_ = std::make_unique<RecoveryModel>(o.recovery_model);
  runner_ = std::make_unique<RecoveryRunner>(fit, *model_);
}

RecoveryPredictionProblem::~RecoveryPredictionProblem() = default;

RecoveryPrediction predict_recovery(const RecoveryPredictionProblem& problem,
                                    const InferenceResult& fit, int draws,
                                    const Executor& executor_in, const ProgressSink& progress) {
  if (draws < 0)
    throw std::invalid_argument("--predict-draws must be >= 0, got " + std::to_string(draws));
  const auto t0 = std::chrono::steady_clock::now();
  const InferenceProblem& fp = problem.fit();
  const InferOptions& o = fp.options();
  const int n = static_cast<int>(fit.samples.rows()), d = static_cast<int>(fit.samples.cols());
  if (n == 0) throw std::invalid_argument("predict_recovery: the fit has no posterior samples");
  const std::vector<double> weight(n, 1.0);  // the final samples are equally weighted
  std::vector<int> index;
  if (draws == 0 || draws >= n) {
    for (int i = 0; i < n; ++i) index.push_back(i);
  } else {
    index = predictive_draws(weight, draws, o.sampler.seed);
  }
  RecoveryPrediction r;
  r.path = problem.path();
  r.data = problem.data();
  r.draws = static_cast<int>(index.size());
  r.elements = problem.model().options().elements;
  r.eta_m_inferred =
      std::find(o.parameters.begin(), o.parameters.end(), Parameter::eta_m) != o.parameters.end();
  r.eta_spread_inferred = std::find(o.parameters.begin(), o.parameters.end(),
                                    Parameter::eta_spread) != o.parameters.end();
  const PriorRange eta_prior = default_prior(Parameter::eta_m);
  r.eta_m_lower = eta_prior.lower;
  r.eta_m_upper = eta_prior.upper;
  for (size_t k = 0; k < fp.slots().size(); ++k)
    if (fp.slots()[k].parameter == Parameter::eta_m) {
      r.eta_m_lower = fp.prior().lower[k];
      r.eta_m_upper = fp.prior().upper[k];
    }
  // One trajectory per distinct physical parameter set; eta_m per draw.
  std::map<std::array<double, 4>, int> run_of;
  std::vector<ChainTask> tasks;
  std::vector<int> run_of_draw;
  std::vector<double> eta_of_draw, spread_of_draw;
  for (size_t j = 0; j < index.size(); ++j) {
    std::vector<double> theta(d);
    for (int k = 0; k < d; ++k) theta[k] = fit.samples(index[j], k);
    const ForwardParameters p = fp.physical(theta);
    const std::array<double, 4> key = {p.persistence_nm, p.lmax_nm, p.kappa_J, p.contact_fraction};
    auto [it, added] = run_of.emplace(key, static_cast<int>(tasks.size()));
    if (added) {
      ChainTask t;
      t.index = static_cast<int>(tasks.size());
      t.theta = theta;
      tasks.push_back(std::move(t));
    }
    run_of_draw.push_back(it->second);
    spread_of_draw.push_back(fp.eta_spread(theta));
    if (r.eta_m_inferred) {
      eta_of_draw.push_back(fp.eta_m(theta));
    } else {
      std::mt19937_64 gen(stream_seed(o.sampler.seed, 0, static_cast<int>(j), kEtaDrawPurpose));
      const double u = static_cast<double>(gen() >> 11) * 0x1.0p-53;  // [0, 1), portable
      eta_of_draw.push_back(r.eta_m_lower + u * (r.eta_m_upper - r.eta_m_lower));
    }
  }
  r.trajectories = static_cast<int>(tasks.size());
  {
    std::ostringstream m;
    m << "predicting recovery data " << r.path << ": " << r.draws << " posterior draws, "
      << r.trajectories << " release trajectories (" << r.elements << " elements), "
      << r.eta_m_text();
    report(progress, m.str());
  }
  {
    // One BLAS thread while the trajectories run (as the fit's forward runs).
    const ScopedProcessBlasThreads single_blas(1);
    const Executor executor =
        executor_in ? executor_in
                    : omp_executor(fp.prior(), problem.runner(), o.threads, o.sampler.cancel);
    StageSetup setup;  // chain_length 0: evaluate each task's theta once
    setup.seed = o.sampler.seed;
    executor(setup, tasks);
  }
  for (const ChainTask& t : tasks) r.failed_runs += t.counts.failed > 0;
  std::vector<RecoveryCurve> curves(tasks.size());
  std::vector<bool> ok(tasks.size(), false);
  for (size_t t = 0; t < tasks.size(); ++t) {
    if (!(tasks[t].log_likelihood > -kUnboundedLogL) || tasks[t].state.empty()) continue;
    curves[t] = recovery_curve_from_state(tasks[t].state);
    ok[t] = true;
  }
  // Per used draw: the cells' nuisance modes and the model's lambda at each reading.
  const size_t nc = r.data.cells.size();
  std::vector<std::vector<std::vector<double>>> mean(nc);  // [cell][reading][draw]
  std::vector<std::vector<double>> lambda_inf(nc), lambda_0(nc);
  for (size_t c = 0; c < nc; ++c) mean[c].resize(r.data.cells[c].time_s.size());
  std::vector<double> tc, eta;
  for (size_t j = 0; j < index.size(); ++j) {
    const int t = run_of_draw[j];
    if (!ok[t]) continue;
    const RecoveryCurve& curve = curves[t];
    const double eta_m = eta_of_draw[j];
    // Each cell's viscosity: eta_m, or with eta-spread its own draw about it.
    std::vector<double> eta_cell(nc, eta_m);
    RecoveryLikelihood l;
    if (spread_of_draw[j] == 0) {
      l = evaluate_recovery_likelihood(curve, eta_m, r.data, o.recovery_likelihood);
    } else {
      for (size_t c = 0; c < nc; ++c) {
        eta_cell[c] =
            eta_m * std::exp(spread_of_draw[j] *
                             cell_normal(o.sampler.seed, static_cast<int>(c), static_cast<int>(j)));
        RecoveryData one;
        one.cells = {r.data.cells[c]};
        one.sigma_ratio = r.data.sigma_ratio;
        const RecoveryLikelihood lc =
            evaluate_recovery_likelihood(curve, eta_cell[c], one, o.recovery_likelihood);
        l.cells.insert(l.cells.end(), lc.cells.begin(), lc.cells.end());
      }
    }
    const bool fitted =
        l.cells.size() == nc && std::all_of(l.cells.begin(), l.cells.end(),
                                            [](const RecoveryCellFit& f) { return f.converged; });
    if (!fitted) {
      ++r.failed_fits;
      continue;
    }
    for (size_t c = 0; c < nc; ++c) {
      // data time t is reference time t s
      const double s = curve.eta_ref_pN_s_per_um / eta_cell[c];
      const RecoveryCellFit& f = l.cells[c];
      const RecoveryCell& cell = r.data.cells[c];
      for (size_t i = 0; i < cell.time_s.size(); ++i) {
        const double x = f.r0 * curve.at(cell.time_s[i] * s);
        mean[c][i].push_back(f.lambda_inf * (1 + x) / (1 - x));
      }
      lambda_inf[c].push_back(f.lambda_inf);
      lambda_0[c].push_back(f.lambda_0);
    }
    tc.push_back(eta_m / curve.shear_modulus_pN_per_um);
    eta.push_back(eta_m);
    ++r.used_draws;
  }
  if (r.used_draws == 0)
    throw std::runtime_error("--predict " + r.path + ": no posterior draw gave a prediction (" +
                             std::to_string(r.failed_runs) + " of " +
                             std::to_string(r.trajectories) + " release trajectories failed, " +
                             std::to_string(r.failed_fits) + " nuisance fits failed)");
  const std::vector<double> sd(r.used_draws, r.data.sigma_ratio), w(r.used_draws, 1.0);
  for (size_t c = 0; c < nc; ++c) {
    const RecoveryCell& cell = r.data.cells[c];
    RecoveryCellPrediction cp;
    cp.id = cell.id;
    cp.time_s = cell.time_s;
    cp.observed = cell.length_over_width;
    cp.lambda_inf = median_of(lambda_inf[c]);
    cp.lambda_0 = median_of(lambda_0[c]);
    for (size_t i = 0; i < cell.time_s.size(); ++i) {
      const std::vector<double>& m = mean[c][i];
      cp.q05.push_back(mixture_quantile(m, sd, w, 0.05));
      cp.q25.push_back(mixture_quantile(m, sd, w, 0.25));
      cp.q50.push_back(mixture_quantile(m, sd, w, 0.50));
      cp.q75.push_back(mixture_quantile(m, sd, w, 0.75));
      cp.q95.push_back(mixture_quantile(m, sd, w, 0.95));
      const double y = cp.observed[i];
      cp.in_50 += cp.q25[i] <= y && y <= cp.q75[i];
      cp.in_90 += cp.q05[i] <= y && y <= cp.q95[i];
    }
    r.cells.push_back(std::move(cp));
  }
  const Summary tcs =
      summarise("t_c", "s", Eigen::Map<const Eigen::VectorXd>(tc.data(), tc.size()));
  r.tc_q05_s = tcs.q05;
  r.tc_q50_s = tcs.q50;
  r.tc_q95_s = tcs.q95;
  const Summary es =
      summarise("eta_m", "pN s/um", Eigen::Map<const Eigen::VectorXd>(eta.data(), eta.size()));
  r.eta_m_q05 = es.q05;
  r.eta_m_q50 = es.q50;
  r.eta_m_q95 = es.q95;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  {
    std::ostringstream msg;
    msg << std::fixed << std::setprecision(2) << "predicted recovery data " << r.path << ": "
        << r.fraction_50() << " of " << r.points() << " readings inside the 50 % band, "
        << r.fraction_90() << " inside the 90 % band"
        << (r.failed_runs ? " (" + std::to_string(r.failed_runs) + " trajectories failed)" : "")
        << ", " << std::setprecision(1) << r.wall_s << " s";
    report(progress, msg.str());
  }
  return r;
}

nlohmann::json recovery_prediction_json(const RecoveryPrediction& p) {
  using nlohmann::json;
  json cells = json::array();
  for (const RecoveryCellPrediction& c : p.cells) {
    const auto norm = [&](const std::vector<double>& v) {
      std::vector<double> out;
      for (double x : v) out.push_back(c.normalised(x));
      return out;
    };
    cells.push_back({{"cell", c.id},
                     {"time_s", c.time_s},
                     {"points", c.points()},
                     {"lambda_inf", c.lambda_inf},
                     {"lambda_0", c.lambda_0},
                     {"length_over_width",
                      {{"observed", c.observed},
                       {"q05", c.q05},
                       {"q25", c.q25},
                       {"q50", c.q50},
                       {"q75", c.q75},
                       {"q95", c.q95}}},
                     {"normalised_recovery",
                      {{"observed", norm(c.observed)},
                       {"q05", norm(c.q05)},
                       {"q25", norm(c.q25)},
                       {"q50", norm(c.q50)},
                       {"q75", norm(c.q75)},
                       {"q95", norm(c.q95)}}},
                     {"inside_50", c.in_50},
                     {"inside_90", c.in_90},
                     {"band_50", c.points() ? static_cast<double>(c.in_50) / c.points() : 0.0},
                     {"band_90", c.points() ? static_cast<double>(c.in_90) / c.points() : 0.0}});
  }
  return {{"kind", "recovery"},
          {"name", data_file_stem(p.path)},
          {"path", p.path},
          {"sigma",
           "reading uncertainty " + number_text(p.data.sigma_ratio) + " in the length over width"},
          {"sigma_ratio", p.data.sigma_ratio},
          {"eta_m_source", p.eta_m_text()},
          {"eta_m_inferred", p.eta_m_inferred},
          {"eta_m_prior_pN_s_per_um", {p.eta_m_lower, p.eta_m_upper}},
          {"eta_m_quantiles_pN_s_per_um", {p.eta_m_q05, p.eta_m_q50, p.eta_m_q95}},
          {"kelvin_voigt_time_quantiles_s", {p.tc_q05_s, p.tc_q50_s, p.tc_q95_s}},
          {"nuisances",
           "lambda_0 and lambda_inf of each cell at each draw: the mode of the likelihood's "
           "fit to the cell's own readings (the prediction is of the curve's shape in time)"},
          {"draws", p.draws},
          {"used_draws", p.used_draws},
          {"trajectories", p.trajectories},
          {"failed_trajectories", p.failed_runs},
          {"failed_nuisance_fits", p.failed_fits},
          {"elements", p.elements},
          {"quantiles", {0.05, 0.25, 0.5, 0.75, 0.95}},
          {"cells", cells},
          {"coverage",
           {{"points", p.points()},
            {"inside_50", p.in_50()},
            {"inside_90", p.in_90()},
            {"band_50", p.fraction_50()},
            {"band_90", p.fraction_90()}}}};
}

void write_recovery_prediction(const RecoveryPrediction& p, const std::string& dir,
                               const std::string& stem, const std::string& fit_label,
                               const std::vector<std::string>& comments) {
  ensure_output_directory(dir);
  const std::vector<std::string> header = {"cell",
                                           "time_s",
                                           "q05",
                                           "q25",
                                           "q50",
                                           "q75",
                                           "q95",
                                           "observed",
                                           "normalised_q05",
                                           "normalised_q25",
                                           "normalised_q50",
                                           "normalised_q75",
                                           "normalised_q95",
                                           "normalised_observed"};
  const auto rows_of = [](const RecoveryCellPrediction& c, CsvTable& t) {
    for (int i = 0; i < c.points(); ++i)
      t.rows.push_back({static_cast<double>(c.id), c.time_s[i], c.q05[i], c.q25[i], c.q50[i],
                        c.q75[i], c.q95[i], c.observed[i], c.normalised(c.q05[i]),
                        c.normalised(c.q25[i]), c.normalised(c.q50[i]), c.normalised(c.q75[i]),
                        c.normalised(c.q95[i]), c.normalised(c.observed[i])});
  };
  CsvTable all;
  all.comments = comments;
  all.comments.push_back(
      "posterior predictive of held-out recovery data " + p.path + " from the fit to " + fit_label +
      ": quantiles of the length over width lambda (q..) plus the reading noise, and of the "
      "normalised recovery (lambda - lambda_inf)/(lambda + lambda_inf) with the cell's median "
      "lambda_inf over the draws");
  all.comments.push_back(p.eta_m_text() +
                         "; each cell's lambda_0, lambda_inf at each draw: the "
                         "mode of the likelihood's fit to its own readings");
  all.comments.push_back("sigma: reading uncertainty " + number_text(p.data.sigma_ratio) + "; " +
                         std::to_string(p.draws) + " posterior draws, " +
                         std::to_string(p.trajectories) + " release trajectories (" +
                         std::to_string(p.failed_runs) + " failed)");
  all.header = header;
  for (const RecoveryCellPrediction& c : p.cells) rows_of(c, all);
  write_csv((fs::path(dir) / (stem + ".csv")).string(), all);

  PlotSpec s;
  s.title = "Recovery data " + plot_literal(data_file_stem(p.path)) +
            " (held out) predicted from the fit to " + plot_literal(fit_label);
  std::ostringstream label;
  label << std::fixed << std::setprecision(0) << "inside the 50 % band: " << 100 * p.fraction_50()
        << " % of " << p.points() << " readings; inside the 90 % band: " << 100 * p.fraction_90()
        << " %";
  std::ostringstream eta;
  if (p.eta_m_inferred)
    eta << "η_{m} from the posterior";
  else
    eta << "η_{m} not inferred, drawn from its prior " << number_text(p.eta_m_lower, 3) << " to "
        << number_text(p.eta_m_upper, 3) << " pN s/µm";
  s.extra_commands = {"set label 1 '" + label.str() + "' at graph 0.35, graph 0.95 left",
                      "set label 2 '" + eta.str() + "' at graph 0.35, graph 0.90 left"};
  s.xlabel = "time (s)";
  s.ylabel = "normalised recovery (λ - λ_{∞})/(λ + λ_{∞})";
  s.key = "outside right top";
  s.width_px = 1400;
  s.height_px = 750;
  const std::vector<std::string> colours = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                                            "#ff7f0e", "#8c564b", "#e377c2", "#7f7f7f"};
  const std::string wide = "filledcurves fs transparent solid 0.15 noborder";
  const std::string narrow = "filledcurves fs transparent solid 0.35 noborder";
  for (size_t k = 0; k < p.cells.size(); ++k) {
    const RecoveryCellPrediction& c = p.cells[k];
    CsvTable t;
    t.comments = {"cell " + std::to_string(c.id) + " of " + stem + ".csv (columns as there)"};
    t.header = header;
    rows_of(c, t);
    const std::string csv = stem + "_cell" + std::to_string(c.id) + ".csv";
    write_csv((fs::path(dir) / csv).string(), t);
    const std::string colour = colours[k % colours.size()];
    const std::string cell = "cell " + std::to_string(c.id);
    s.series.push_back({cell + " 90 % predictive band", csv, "2:9:13", wide, colour});
    s.series.push_back({cell + " 50 % band", csv, "2:10:12", narrow, colour});
    s.series.push_back({cell + " median", csv, "2:11", "lines", colour});
    s.series.push_back({cell + " readings", csv, "2:14", "points", colour, 7});
  }
  render_plot(s, dir, stem);
}

}  // namespace rbc
