// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/predictive.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>

#include "compare/experiment.hpp"
#include "compare/plot.hpp"
#include "core/blas_threads.hpp"
#include "core/io.hpp"

namespace rbc {

namespace {
namespace fs = std::filesystem;
constexpr double kInf = std::numeric_limits<double>::infinity();
/// stream_seed's purpose of the predictive draws (the sampler's own are 1 to 3).
constexpr int kPredictiveDrawPurpose = 4;

/// Forward runs at the held-out forces, in the Likelihood shape the executors run.
class HeldOutRunner final : public Likelihood {
 public:
  HeldOutRunner(const InferenceProblem& fit, const ForwardModel& forward)
      : fit_(fit), forward_(forward) {}
  int dimension() const override { return fit_.prior().dimension(); }
  LikelihoodValue evaluate(std::span<const double> theta, const WarmState&,
                           WarmState* state_out) const override {
    // Always from the rest shape: the result depends on the parameters alone.
    const ForwardRun run = forward_.run(fit_.physical(theta), WarmState{});
    LikelihoodValue v;
    v.retried = run.retried;
    v.symmetry_broken = run.symmetry_broken;
    if (!run.converged) {
      v.failed = true;
      v.log_likelihood = -kInf;
      return v;
    }
    if (state_out) {
      state_out->assign(run.diameters.axial_um.begin(), run.diameters.axial_um.end());
      state_out->insert(state_out->end(), run.diameters.transverse_um.begin(),
                        run.diameters.transverse_um.end());
    }
    return v;
  }

 private:
  const InferenceProblem& fit_;
  const ForwardModel& forward_;
};

double mixture_cdf(std::span<const double> mean, std::span<const double> sd,
                   std::span<const double> weight, double x) {
  double f = 0;
  for (size_t i = 0; i < mean.size(); ++i) {
    if (weight[i] == 0) continue;
    const double c = sd[i] > 0 ? 0.5 * std::erfc(-(x - mean[i]) / (sd[i] * std::sqrt(2.0)))
                               : (x >= mean[i] ? 1.0 : 0.0);
    f += weight[i] * c;
  }
  return f;
}

std::string format(double v) {
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return s.str();
}

/// A file-name-safe stem: letters, digits, '-', '_' and '.' kept, others as '_'.
std::string safe_stem(const std::string& path) {
  std::string s = fs::path(path).stem().string();
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) c = '_';
  return s.empty() ? "data" : s;
}
}  // namespace

double mixture_quantile(std::span<const double> mean, std::span<const double> sd,
                        std::span<const double> weight, double q) {
  if (mean.size() != sd.size() || mean.size() != weight.size() || mean.empty())
    throw std::invalid_argument(
        "mixture_quantile: means, sds and weights must be non-empty and "
        "of one size");
  if (!(q > 0 && q < 1))
    throw std::invalid_argument("mixture_quantile: quantile must lie in (0, 1), got " + format(q));
  double total = 0, lo = kInf, hi = -kInf;
  for (size_t i = 0; i < mean.size(); ++i) {
    if (!(weight[i] >= 0) || !std::isfinite(weight[i]))
      throw std::invalid_argument("mixture_quantile: weight " + format(weight[i]) +
                                  ": expected a finite weight >= 0");
    if (!(sd[i] >= 0) || !std::isfinite(sd[i]) || !std::isfinite(mean[i]))
      throw std::invalid_argument("mixture_quantile: component " + format(mean[i]) + " +- " +
                                  format(sd[i]) + ": expected a finite mean and sd >= 0");
    total += weight[i];
    if (weight[i] > 0) {
      // 40 sd from every mean: the normal tail beyond is below 1e-300.
      lo = std::min(lo, mean[i] - 40 * sd[i]);
      hi = std::max(hi, mean[i] + 40 * sd[i]);
    }
  }
  if (!(total > 0)) throw std::invalid_argument("mixture_quantile: every weight is 0");
  const double target = q * total;
  // Invariant: F(lo) < target <= F(hi). F(hi) = total there; below lo it is 0.
  const double scale = std::max({1.0, std::abs(lo), std::abs(hi)});
  lo -= 1e-9 * scale;
  const double tolerance = 1e-13 * scale;
  for (int it = 0; it < 200 && hi - lo > tolerance; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mixture_cdf(mean, sd, weight, mid) >= target)
      hi = mid;
    else
      lo = mid;
  }
  return hi;
}

std::vector<int> predictive_draws(std::span<const double> weight, int draws, std::uint64_t seed) {
  if (draws <= 0)
    throw std::invalid_argument("predictive draws must be > 0, got " + std::to_string(draws));
  double total = 0;
  for (double w : weight) {
    if (!(w >= 0) || !std::isfinite(w))
      throw std::invalid_argument("predictive draws: weight " + format(w) +
                                  ": expected a finite weight >= 0");
    total += w;
  }
  if (weight.empty() || !(total > 0))
    throw std::invalid_argument("predictive draws: no sample of positive weight");
  std::mt19937_64 gen(stream_seed(seed, 0, 0, kPredictiveDrawPurpose));
  const double u = static_cast<double>(gen() >> 11) * 0x1.0p-53;  // [0, 1), portable
  std::vector<int> out;
  out.reserve(draws);
  // Systematic resampling: points (u + m) / draws, m = 0..draws-1, on the cumulative weights.
  double cum = 0;
  size_t i = 0;
  for (int m = 0; m < draws; ++m) {
    const double t = (u + m) / draws * total;
    while (i + 1 < weight.size() && (cum + weight[i] <= t || weight[i] == 0)) cum += weight[i++];
    out.push_back(static_cast<int>(i));
  }
  return out;
}

double PredictiveCoverage::fraction_50() const {
  return points() ? static_cast<double>(axial_in_50 + transverse_in_50) / points() : 0.0;
}

double PredictiveCoverage::fraction_90() const {
  return points() ? static_cast<double>(axial_in_90 + transverse_in_90) / points() : 0.0;
}

PredictiveCoverage predictive_coverage(const DiameterData& data, const PredictiveBand& axial,
                                       const PredictiveBand& transverse) {
  PredictiveCoverage c;
  const auto inside = [](double y, double lo, double hi) { return lo <= y && y <= hi; };
  for (int k = 0; k < data.size(); ++k) {
    ++c.axial_points;
    c.axial_in_50 += inside(data.axial_um[k], axial.q25[k], axial.q75[k]);
    c.axial_in_90 += inside(data.axial_um[k], axial.q05[k], axial.q95[k]);
    if (!data.transverse_used[k]) continue;
    ++c.transverse_points;
    c.transverse_in_50 += inside(data.transverse_um[k], transverse.q25[k], transverse.q75[k]);
    c.transverse_in_90 += inside(data.transverse_um[k], transverse.q05[k], transverse.q95[k]);
  }
  return c;
}

PredictionProblem::PredictionProblem(const InferenceProblem& fit, const std::string& path)
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
  data_ = load_diameter_data(path, o.extra_uncertainty_um, o.method.kind);
  ForwardOptions fo = fit.forward().options();
  fo.forces_pN = data_.force_pN;
  forward_ = std::make_unique<ForwardModel>(fo);
  runner_ = std::make_unique<HeldOutRunner>(fit, *forward_);
}

PredictionProblem::~PredictionProblem() = default;

HeldOutPrediction predict_held_out(const PredictionProblem& problem, const InferenceResult& fit,
                                   int draws, const Executor& executor_in,
                                   const ProgressSink& progress) {
  if (draws < 0)
    throw std::invalid_argument("--predict-draws must be >= 0, got " + std::to_string(draws));
  const auto t0 = std::chrono::steady_clock::now();
  const InferenceProblem& fp = problem.fit();
  const InferOptions& o = fp.options();
  const int n = static_cast<int>(fit.samples.rows()), d = static_cast<int>(fit.samples.cols());
  if (n == 0) throw std::invalid_argument("predict_held_out: the fit has no posterior samples");
  // TMCMC's final samples are equally weighted.
  const std::vector<double> weight(n, 1.0);
  std::vector<int> index;
  if (draws == 0 || draws >= n) {
    for (int i = 0; i < n; ++i) index.push_back(i);
  } else {
    index = predictive_draws(weight, draws, o.sampler.seed);
  }
  // One forward run per distinct physical parameter set.
  std::map<std::array<double, 4>, int> run_of;
  std::vector<ChainTask> tasks;
  std::vector<int> run_of_draw;
  for (int i : index) {
    std::vector<double> theta(d);
    for (int k = 0; k < d; ++k) theta[k] = fit.samples(i, k);
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
  }
  HeldOutPrediction r;
  r.path = problem.path();
  r.data = problem.data();
  r.draws = static_cast<int>(index.size());
  r.forward_runs = static_cast<int>(tasks.size());
  r.fixed_sigma_scale = o.fixed_sigma_scale;
  r.sigma_scaled = std::find(o.parameters.begin(), o.parameters.end(), Parameter::sigma_scale) !=
                   o.parameters.end();
  {
    std::ostringstream m;
    m << "predicting " << r.data.name << " (" << r.path << "): " << r.draws << " posterior draws, "
      << r.forward_runs << " forward runs at " << r.data.size() << " forces";
    report(progress, m.str());
  }
  {
    // The fit's setting: one BLAS thread while the forward runs are made (forward_model.hpp).
    const ScopedProcessBlasThreads single_blas(1);
    const Executor executor =
        executor_in ? executor_in
                    : omp_executor(fp.prior(), problem.runner(), o.threads, o.sampler.cancel);
    StageSetup setup;  // chain_length 0: evaluate each task's theta once
    setup.seed = o.sampler.seed;
    executor(setup, tasks);
  }
  const int nf = r.data.size();
  // Mixture components per force: one per draw whose run converged.
  std::vector<double> weight_used, scale;
  std::vector<int> run_used;
  for (size_t j = 0; j < index.size(); ++j) {
    const ChainTask& t = tasks[run_of_draw[j]];
    if (!(t.log_likelihood > -kInf) || t.state.size() != static_cast<size_t>(2 * nf)) continue;
    std::vector<double> theta(d);
    for (int k = 0; k < d; ++k) theta[k] = fit.samples(index[j], k);
    weight_used.push_back(weight[index[j]]);
    scale.push_back(fp.sigma_scale(theta));
    run_used.push_back(run_of_draw[j]);
  }
  for (const ChainTask& t : tasks) r.failed_runs += t.counts.failed > 0;
  if (weight_used.empty())
    throw std::runtime_error("--predict " + r.path + ": every forward run of the " +
                             std::to_string(r.forward_runs) + " failed");
  const size_t m = weight_used.size();
  std::vector<double> mean(m), sd(m);
  const auto band = [&](int offset, const std::vector<double>& sigma, PredictiveBand& b) {
    for (int k = 0; k < nf; ++k) {
      for (size_t j = 0; j < m; ++j) {
        mean[j] = tasks[run_used[j]].state[offset + k];
        sd[j] = scale[j] * sigma[k];
      }
      b.q05.push_back(mixture_quantile(mean, sd, weight_used, 0.05));
      b.q25.push_back(mixture_quantile(mean, sd, weight_used, 0.25));
      b.q50.push_back(mixture_quantile(mean, sd, weight_used, 0.50));
      b.q75.push_back(mixture_quantile(mean, sd, weight_used, 0.75));
      b.q95.push_back(mixture_quantile(mean, sd, weight_used, 0.95));
    }
  };
  band(0, r.data.axial_sigma_um, r.axial);
  band(nf, r.data.transverse_sigma_um, r.transverse);
  r.coverage = predictive_coverage(r.data, r.axial, r.transverse);
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  {
    std::ostringstream msg;
    msg << std::fixed << std::setprecision(2) << "predicted " << r.data.name << ": "
        << r.coverage.fraction_50() << " of " << r.coverage.points()
        << " points inside the 50 % band, " << r.coverage.fraction_90() << " inside the 90 % band"
        << (r.failed_runs ? " (" + std::to_string(r.failed_runs) + " forward runs failed)" : "")
        << ", " << std::setprecision(1) << r.wall_s << " s";
    report(progress, msg.str());
  }
  return r;
}

std::string prediction_sigma_text(const HeldOutPrediction& p) {
  std::string sigma = sigma_text(p.data);
  if (p.sigma_scaled)
    sigma += "; times each draw's sigma-scale";
  else if (p.fixed_sigma_scale != 1)
    sigma += "; times sigma-scale " + format(p.fixed_sigma_scale);
  return sigma;
}

nlohmann::json predictions_json(const std::vector<HeldOutPrediction>& predictions) {
  using nlohmann::json;
  json out = json::array();
  for (const HeldOutPrediction& p : predictions) {
    json points = json::array();
    const auto value = [](double observed, double sigma, const PredictiveBand& b, int k) {
      return json{{"observed", observed}, {"sigma", sigma},  {"q05", b.q05[k]}, {"q25", b.q25[k]},
                  {"q50", b.q50[k]},      {"q75", b.q75[k]}, {"q95", b.q95[k]}};
    };
    for (int k = 0; k < p.data.size(); ++k) {
      json t = value(p.data.transverse_um[k], p.data.transverse_sigma_um[k], p.transverse, k);
      t["used"] = p.data.transverse_used[k] != 0;
      points.push_back(
          {{"force_pN", p.data.force_pN[k]},
           {"axial_um", value(p.data.axial_um[k], p.data.axial_sigma_um[k], p.axial, k)},
           {"transverse_um", t}});
    }
    const PredictiveCoverage& c = p.coverage;
    const auto frac = [](int in, int of) { return of ? static_cast<double>(in) / of : 0.0; };
    const std::string sigma = prediction_sigma_text(p);
    out.push_back(
        {{"name", p.data.name},
         {"path", p.path},
         {"sigma", sigma},
         {"declared_extra_uncertainty_um", p.data.declared_extra_uncertainty_um},
         {"added_extra_uncertainty_um", p.data.added_extra_uncertainty_um},
         {"draws", p.draws},
         {"forward_runs", p.forward_runs},
         {"failed_forward_runs", p.failed_runs},
         {"quantiles", {0.05, 0.25, 0.5, 0.75, 0.95}},
         {"points", points},
         {"coverage",
          {{"points",
            {{"axial", c.axial_points}, {"transverse", c.transverse_points}, {"all", c.points()}}},
           {"inside_50",
            {{"axial", c.axial_in_50},
             {"transverse", c.transverse_in_50},
             {"all", c.axial_in_50 + c.transverse_in_50}}},
           {"inside_90",
            {{"axial", c.axial_in_90},
             {"transverse", c.transverse_in_90},
             {"all", c.axial_in_90 + c.transverse_in_90}}},
           {"band_50",
            {{"axial", frac(c.axial_in_50, c.axial_points)},
             {"transverse", frac(c.transverse_in_50, c.transverse_points)},
             {"all", c.fraction_50()}}},
           {"band_90",
            {{"axial", frac(c.axial_in_90, c.axial_points)},
             {"transverse", frac(c.transverse_in_90, c.transverse_points)},
             {"all", c.fraction_90()}}}}}});
  }
  return out;
}

std::vector<std::string> prediction_file_stems(const std::vector<HeldOutPrediction>& predictions) {
  std::vector<std::string> paths;
  for (const HeldOutPrediction& p : predictions) paths.push_back(p.path);
  return prediction_file_stems(paths);
}

std::vector<std::string> prediction_file_stems(const std::vector<std::string>& paths) {
  std::vector<std::string> out;
  std::set<std::string> taken;
  for (const std::string& path : paths) {
    const std::string base = "predict_" + safe_stem(path);
    std::string stem = base;
    for (int k = 2; taken.count(stem); ++k) stem = base + "_" + std::to_string(k);
    taken.insert(stem);
    out.push_back(stem);
  }
  return out;
}

void write_predictions(const std::vector<HeldOutPrediction>& predictions, const std::string& dir,
                       const std::string& fit_label, const std::vector<std::string>& comments) {
  ensure_output_directory(dir);
  const std::vector<std::string> stems = prediction_file_stems(predictions);
  for (size_t i = 0; i < predictions.size(); ++i) {
    const HeldOutPrediction& p = predictions[i];
    CsvTable t;
    t.comments = comments;
    t.comments.push_back("posterior predictive of held-out data " + p.data.name + " (" + p.path +
                         ") from the fit to " + fit_label +
                         ": quantiles of the model diameters plus the held-out file's noise");
    t.comments.push_back("sigma: " + prediction_sigma_text(p));
    t.comments.push_back(std::to_string(p.draws) + " posterior draws, " +
                         std::to_string(p.forward_runs) + " forward runs (" +
                         std::to_string(p.failed_runs) + " failed)");
    t.header = {"force_pN",
                "axial_q05_um",
                "axial_q25_um",
                "axial_q50_um",
                "axial_q75_um",
                "axial_q95_um",
                "transverse_q05_um",
                "transverse_q25_um",
                "transverse_q50_um",
                "transverse_q75_um",
                "transverse_q95_um",
                "data_axial_um",
                "data_axial_sigma_um",
                "data_transverse_um",
                "data_transverse_sigma_um"};
    for (int k = 0; k < p.data.size(); ++k)
      t.rows.push_back({p.data.force_pN[k], p.axial.q05[k], p.axial.q25[k], p.axial.q50[k],
                        p.axial.q75[k], p.axial.q95[k], p.transverse.q05[k], p.transverse.q25[k],
                        p.transverse.q50[k], p.transverse.q75[k], p.transverse.q95[k],
                        p.data.axial_um[k], p.data.axial_sigma_um[k], p.data.transverse_um[k],
                        p.data.transverse_sigma_um[k]});
    const std::string csv = stems[i] + ".csv";
    write_csv((fs::path(dir) / csv).string(), t);
    PlotSpec s;
    s.title = experiment_plot_label(p.data.name) + " (held out) predicted from the fit to " +
              experiment_plot_label(fit_label);
    std::ostringstream coverage;
    coverage << std::fixed << std::setprecision(0)
             << "inside the 50 % band: " << 100 * p.coverage.fraction_50() << " % of "
             << p.coverage.points()
             << " points; inside the 90 % band: " << 100 * p.coverage.fraction_90() << " %";
    s.extra_commands = {"set label 1 '" + coverage.str() + "' at graph 0.02, graph 0.95 left"};
    s.xlabel = "force (pN)";
    s.ylabel = "diameter (µm)";
    // The key beside the plot: inside, it would hide the bands of one data set or the other.
    s.key = "outside right top";
    s.width_px = 1400;
    s.height_px = 750;
    const std::string wide = "filledcurves fs transparent solid 0.18 noborder";
    const std::string narrow = "filledcurves fs transparent solid 0.4 noborder";
    // The held-out data with the sigma of their likelihood (before sigma-scale), as the fit's
    // predictive plot shows its own data; the title names them.
    std::ostringstream extra;
    extra << std::setprecision(3) << p.data.extra_uncertainty_um();
    const std::string data = "held-out data" + (p.data.extra_uncertainty_um() > 0
                                                    ? " (error bar ⊕ " + extra.str() + " µm)"
                                                    : std::string(" (error bar)"));
    s.series = {{"D_{A} 90 % predictive band", csv, "1:2:6", wide, "#1f77b4"},
                {"D_{A} 50 % band", csv, "1:3:5", narrow, "#1f77b4"},
                {"D_{A} median", csv, "1:4", "lines", "#1f77b4"},
                {"D_{A} " + data, csv, "1:12:13", "yerrorbars", "#000000"},
                {"D_{T} 90 % predictive band", csv, "1:7:11", wide, "#d62728"},
                {"D_{T} 50 % band", csv, "1:8:10", narrow, "#d62728"},
                {"D_{T} median", csv, "1:9", "lines", "#d62728"},
                {"D_{T} " + data, csv, "1:14:15", "yerrorbars", "#555555", 5}};
    render_plot(s, dir, stems[i]);
  }
}

}  // namespace rbc
