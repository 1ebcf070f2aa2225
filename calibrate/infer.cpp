// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/infer.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "calibrate/stage_checkpoint.hpp"
#include "compare/experiment.hpp"
#include "core/blas_threads.hpp"
#include "core/geometry.hpp"
#include "core/units.hpp"
#include "core/validation.hpp"

namespace rbc {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

/// The likelihood of the data under the forward model at a sample: one forward run per group
/// (InferenceProblem), the groups' warm states one after the other.
class DiameterLikelihood final : public Likelihood {
 public:
  DiameterLikelihood(const InferenceProblem& problem) : problem_(problem) {}
  int dimension() const override { return static_cast<int>(problem_.slots().size()); }
  LikelihoodValue evaluate(std::span<const double> theta, const WarmState& warm,
                           WarmState* state_out) const override {
    LikelihoodValue v;
    std::vector<ModelDiameters> diameters;
    WarmState state;
    size_t offset = 0;
    for (int g = 0; g < problem_.groups(); ++g) {
      const size_t size = problem_.group_state_size(g);
      WarmState slice;
      if (warm.size() == problem_.state_size())
        slice.assign(warm.begin() + static_cast<std::ptrdiff_t>(offset),
                     warm.begin() + static_cast<std::ptrdiff_t>(offset + size));
      offset += size;
      ForwardRun run = problem_.forward(g).run(problem_.group_physical(theta, g), slice);
      v.retried = v.retried || run.retried;
      v.symmetry_broken = v.symmetry_broken || run.symmetry_broken;
      if (!run.converged) {
        v.failed = true;
        v.log_likelihood = -kInf;
        return v;
      }
      diameters.push_back(std::move(run.diameters));
      if (state_out) state.insert(state.end(), run.state.begin(), run.state.end());
    }
    v.log_likelihood = problem_.log_likelihood(theta, diameters);
    // Recovery experiments: one release-scene trajectory each, rescaled to eta_m.
    for (size_t e = 0; e < problem_.experiments().size(); ++e) {
      if (problem_.experiments()[e].kind != DataKind::recovery) continue;
      const double l = problem_.recovery_log_likelihood(theta, static_cast<int>(e));
      if (!std::isfinite(l)) {
        v.failed = true;
        v.log_likelihood = -kInf;
        return v;
      }
      v.log_likelihood += l;
    }
    if (state_out) *state_out = std::move(state);
    return v;
  }

 private:
  const InferenceProblem& problem_;
};

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double h = q * (v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(h));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (h - lo) * (v[hi] - v[lo]);
}
}  // namespace

std::string to_string(SamplerKind s) {
  return s == SamplerKind::laplace_is ? "laplace-is" : "tmcmc";
}

void InferOptions::validate() const {
  if (parameters.empty()) throw std::invalid_argument("--params: at least one parameter");
  for (size_t i = 0; i < parameters.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (parameters[i] == parameters[j])
        throw std::invalid_argument("--params: '" + to_string(parameters[i]) + "' is given twice");
  for (size_t i = 0; i < priors.size(); ++i) {
    priors[i].validate();
    if (std::find(parameters.begin(), parameters.end(), priors[i].parameter) == parameters.end())
      throw std::invalid_argument("--prior " + to_string(priors[i].parameter) +
                                  ": the parameter is not inferred (add it to --params)");
    for (size_t j = 0; j < i; ++j)
      if (priors[j].parameter == priors[i].parameter)
        throw std::invalid_argument("--prior " + to_string(priors[i].parameter) +
                                    " is given twice");
  }
  if (!(extra_uncertainty_um >= 0) || !std::isfinite(extra_uncertainty_um))
    throw std::invalid_argument("--extra-uncertainty must be finite and >= 0 um, got " +
                                std::to_string(extra_uncertainty_um));
  if (!(fixed_sigma_scale > 0) || !std::isfinite(fixed_sigma_scale))
    throw std::invalid_argument("sigma scale must be finite and > 0, got " +
                                std::to_string(fixed_sigma_scale));
  if (!(force_tolerance_pN > 0 && force_tolerance_pN <= 0.1))
    throw std::invalid_argument("--force-tolerance must lie in (0, 0.1] pN, got " +
                                std::to_string(force_tolerance_pN));
  if (threads < 0)
    throw std::invalid_argument("--threads must be >= 0, got " + std::to_string(threads));
  fixed.validate();
  // Each sampler's own settings, changed from their defaults for the other sampler, are
  // refused rather than ignored.
  const bool is = sampler_kind == SamplerKind::laplace_is;
  auto other = [&](const std::string& option, const std::string& value) {
    throw std::invalid_argument(option + " " + value + ": a setting of the " +
                                (is ? "tmcmc" : "laplace-is") + " sampler, not of " +
                                to_string(sampler_kind) + "; expected --sampler " +
                                (is ? "tmcmc" : "laplace-is") + " with it");
  };
  const TmcmcOptions d = default_sampler();
  if (is) {
    if (sampler.samples != d.samples) other("--samples", std::to_string(sampler.samples));
    if (sampler.chain_length != d.chain_length)
      other("--chain-length", std::to_string(sampler.chain_length));
    if (sampler.target_cov != d.target_cov)
      other("--target-cov", format_number(sampler.target_cov));
    if (sampler.proposal_scale != d.proposal_scale)
      other("--proposal-scale", format_number(sampler.proposal_scale));
  } else if (is_samples != InferOptions{}.is_samples) {
    other("--is-samples", std::to_string(is_samples));
  } else if (is_rounds != InferOptions{}.is_rounds) {
    other("--is-rounds", std::to_string(is_rounds));
  } else if (min_effective_samples != InferOptions{}.min_effective_samples) {
    other("--min-ess", format_number(min_effective_samples));
  }
  if (!(min_effective_samples >= 0) || !std::isfinite(min_effective_samples))
    throw std::invalid_argument("--min-ess " + format_number(min_effective_samples) +
                                ": expected a finite number >= 0");
  // The sampler's own floor (TmcmcOptions::validate: 5 samples per island), named as the
  // option the user sets.
  if (sampler.samples < 5 * sampler.islands)
    throw std::invalid_argument("--samples " + std::to_string(sampler.samples) +
                                ": expected at least " + std::to_string(5 * sampler.islands) +
                                " samples per stage");
  sampler.validate();
  if (sampler_kind == SamplerKind::laplace_is) {
    if (is_samples < 10)
      throw std::invalid_argument("--is-samples " + std::to_string(is_samples) +
                                  ": expected at least 10");
    if (is_rounds < 1 || is_rounds > is_samples)
      throw std::invalid_argument("--is-rounds " + std::to_string(is_rounds) +
                                  ": expected 1 to --is-samples (" + std::to_string(is_samples) +
                                  ")");
  }
  if (method.resolution <= 0)
    throw std::invalid_argument("--method resolution must be > 0, got " +
                                std::to_string(method.resolution));
  const std::vector<std::string> paths = data_paths();
  for (size_t i = 0; i < paths.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (data_file_stem(paths[i]) == data_file_stem(paths[j]))
        throw std::invalid_argument("--data-file " + paths[i] +
                                    ": another data file has the same name '" +
                                    data_file_stem(paths[i]) +
                                    "'; expected data files whose names (without directory and "
                                    "extension) differ");
  for (size_t i = 0; i < extra_uncertainty_by_file.size(); ++i) {
    const FileExtraUncertainty& e = extra_uncertainty_by_file[i];
    const std::string text = "--extra-uncertainty " + e.stem + "=" + std::to_string(e.um);
    if (!(e.um >= 0) || !std::isfinite(e.um))
      throw std::invalid_argument(text + ": expected a finite uncertainty >= 0 um");
    bool known = false;
    for (const auto& path : paths) known = known || data_file_stem(path) == e.stem;
    if (!known)
      throw std::invalid_argument("--extra-uncertainty " + e.stem +
                                  "=...: no --data-file is named '" + e.stem +
                                  "' (expected the file name without directory and extension)");
    for (size_t j = 0; j < i; ++j)
      if (extra_uncertainty_by_file[j].stem == e.stem)
        throw std::invalid_argument("--extra-uncertainty " + e.stem + "=...: given twice");
  }
  for (size_t i = 0; i < per_experiment.size(); ++i) {
    const Parameter q = per_experiment[i];
    const std::string text = "--per-experiment " + to_string(q);
    if (q != Parameter::persistence && q != Parameter::lmax && q != Parameter::kappa &&
        q != Parameter::contact_fraction)
      throw std::invalid_argument(text +
                                  ": expected a stretch forward-model parameter (persistence, "
                                  "lmax, kappa, contact-fraction)");
    if (std::find(parameters.begin(), parameters.end(), q) == parameters.end())
      throw std::invalid_argument(text + ": the parameter is not inferred (add it to --params)");
    for (size_t j = 0; j < i; ++j)
      if (per_experiment[j] == q) throw std::invalid_argument(text + ": given twice");
  }
}

std::string InferOptions::default_data_file() {
  return default_data_directory() + "/suresh2005_healthy_optical_tweezers.csv";
}

std::string InferOptions::data_path() const {
  return data_paths().front();
}

std::vector<std::string> InferOptions::data_paths() const {
  if (!data_files.empty()) return data_files;
  return {data_file.empty() ? default_data_file() : data_file};
}

double InferOptions::extra_uncertainty_for(const std::string& stem) const {
  for (const auto& e : extra_uncertainty_by_file)
    if (e.stem == stem) return e.um;
  return extra_uncertainty_um;
}

std::string data_file_stem(const std::string& path) {
  return std::filesystem::path(path).stem().string();
}

std::vector<PriorRange> InferOptions::prior_ranges() const {
  std::vector<PriorRange> out;
  for (Parameter p : parameters) {
    PriorRange r = default_prior(p);
    for (const auto& o : priors)
      if (o.parameter == p) r = o;
    out.push_back(r);
  }
  return out;
}

InferenceProblem::InferenceProblem(const InferOptions& options) : options_(options) {
  options_.validate();
  const std::vector<std::string> paths = options_.data_paths();
  for (const std::string& path : paths) {
    Experiment e;
    e.path = path;
    e.stem = data_file_stem(path);
    if (std::filesystem::exists(path)) e.kind = detect_data_kind(path);
    if (e.kind == DataKind::recovery) {
      if (experiments_.empty())
        throw std::invalid_argument("--data-file " + path +
                                    ": recovery data; expected stretch data as the first data "
                                    "file (recovery data may follow)");
      e.recovery = std::make_shared<const RecoveryData>(read_recovery_data(path));
      e.group = -1;
    } else {
      e.data =
          load_diameter_data(path, options_.extra_uncertainty_for(e.stem), options_.method.kind);
    }
    experiments_.push_back(std::move(e));
  }
  const auto inferred = [&](Parameter q) {
    return std::find(options_.parameters.begin(), options_.parameters.end(), q) !=
           options_.parameters.end();
  };
  bool recovery = false;
  for (const auto& e : experiments_) recovery = recovery || e.kind == DataKind::recovery;
  if (recovery) {
    if (!inferred(Parameter::eta_m))
      throw std::invalid_argument(
          "--data-file: recovery data need the membrane viscosity inferred; expected eta-m in "
          "--params");
    if (options_.sampler_kind == SamplerKind::laplace_is && inferred(Parameter::contact_fraction))
      throw std::invalid_argument(
          "--sampler laplace-is: the recovery term's gradient covers persistence, lmax, kappa and "
          "eta-m; expected --sampler tmcmc with contact-fraction inferred");
    if (options_.method.kind != MethodKind::continuum)
      throw std::invalid_argument("--method " + options_.method.name() +
                                  ": recovery data run the continuum release scene; expected "
                                  "--method continuum:ORDER:ELEMENTS");
    options_.recovery_model.validate();
    options_.recovery_likelihood.validate();
    recovery_model_ = std::make_unique<RecoveryModel>(options_.recovery_model);
  }
  if (inferred(Parameter::eta_spread) && !recovery)
    throw std::invalid_argument(
        "--params eta-spread: no recovery data file; the between-cell spread of the membrane "
        "viscosity enters only the recovery likelihood (expected a --data-file with columns "
        "cell,time_s,length_over_width and eta-m in --params)");
  if (inferred(Parameter::eta_m)) {
    if (!recovery)
      throw std::invalid_argument(
          "--params eta-m: no recovery data file; the membrane viscosity enters only the "
          "recovery likelihood (expected a --data-file with columns cell,time_s,"
          "length_over_width)");
  }
  data_ = experiments_.front().data;
  // theta's slots, in the parameters' order, a per-experiment one expanded.
  const std::vector<PriorRange> ranges = options_.prior_ranges();
  std::vector<std::string> names;
  for (size_t k = 0; k < options_.parameters.size(); ++k) {
    const Parameter q = options_.parameters[k];
    const bool own = std::find(options_.per_experiment.begin(), options_.per_experiment.end(), q) !=
                     options_.per_experiment.end();
    const int copies = own ? static_cast<int>(experiments_.size()) : 1;
    for (int e = 0; e < copies; ++e) {
      ParameterSlot slot;
      slot.parameter = q;
      slot.experiment = own ? e : -1;
      slot.name = own ? to_string(q) + "[" + experiments_[e].stem + "]" : to_string(q);
      slots_.push_back(slot);
      prior_.lower.push_back(ranges[k].lower);
      prior_.upper.push_back(ranges[k].upper);
      names.push_back(slot.name);
    }
  }
  prior_.validate(names);
  // Forward-run groups: one over the union of the forces, or one per experiment when some
  // forward parameter is an experiment's own.
  ForwardOptions fo;
  fo.method = options_.method;
  fo.newton.force_tolerance_pN = options_.force_tolerance_pN;
  fo.newton.symmetry = options_.symmetry;
  const bool per_group = !options_.per_experiment.empty();
  std::vector<std::vector<double>> group_forces;
  int stretch = 0;
  for (size_t e = 0; e < experiments_.size(); ++e) {
    Experiment& x = experiments_[e];
    if (x.kind == DataKind::recovery) continue;
    x.group = per_group ? stretch : 0;
    ++stretch;
    if (static_cast<int>(group_forces.size()) <= x.group) group_forces.resize(x.group + 1);
    auto& f = group_forces[x.group];
    f.insert(f.end(), x.data.force_pN.begin(), x.data.force_pN.end());
  }
  for (auto& f : group_forces) {
    std::sort(f.begin(), f.end());
    f.erase(std::unique(f.begin(), f.end()), f.end());
  }
  for (Experiment& x : experiments_) {
    if (x.kind == DataKind::recovery) continue;
    const auto& f = group_forces[x.group];
    for (double force : x.data.force_pN)
      x.force_index.push_back(
          static_cast<int>(std::lower_bound(f.begin(), f.end(), force) - f.begin()));
  }
  for (const auto& f : group_forces) {
    fo.forces_pN = f;
    forwards_.push_back(std::make_unique<ForwardModel>(fo));
  }
  likelihood_ = std::make_unique<DiameterLikelihood>(*this);
}

InferenceProblem::~InferenceProblem() = default;

std::vector<std::string> InferenceProblem::names() const {
  std::vector<std::string> out;
  for (const auto& s : slots_) out.push_back(s.name);
  return out;
}

std::vector<std::string> InferenceProblem::units() const {
  std::vector<std::string> out;
  for (const auto& s : slots_) out.push_back(unit_of(s.parameter));
  return out;
}

size_t InferenceProblem::group_state_size(int group) const {
  return forwards_[group]->options().forces_pN.size() *
         (3 * static_cast<size_t>(forwards_[group]->vertices()) + 2);
}

size_t InferenceProblem::state_size() const {
  size_t n = 0;
  for (int g = 0; g < groups(); ++g) n += group_state_size(g);
  return n;
}

ForwardParameters InferenceProblem::physical(std::span<const double> theta) const {
  return physical(theta, 0);
}

ForwardParameters InferenceProblem::physical(std::span<const double> theta, int experiment) const {
  ForwardParameters p = options_.fixed;
  for (size_t k = 0; k < slots_.size(); ++k) {
    if (slots_[k].experiment >= 0 && slots_[k].experiment != experiment) continue;
    switch (slots_[k].parameter) {
      case Parameter::persistence:
        p.persistence_nm = theta[k];
        break;
      case Parameter::lmax:
        p.lmax_nm = theta[k];
        break;
      case Parameter::kappa:
        p.kappa_J = theta[k];
        break;
      case Parameter::contact_fraction:
        p.contact_fraction = theta[k];
        break;
      case Parameter::sigma_scale:
      case Parameter::eta_m:
      case Parameter::tau:
      case Parameter::eta_spread:
        break;
    }
  }
  return p;
}

ForwardParameters InferenceProblem::group_physical(std::span<const double> theta, int group) const {
  for (size_t e = 0; e < experiments_.size(); ++e)
    if (experiments_[e].group == group) return physical(theta, static_cast<int>(e));
  return physical(theta, 0);
}

double InferenceProblem::sigma_scale(std::span<const double> theta) const {
  for (size_t k = 0; k < slots_.size(); ++k)
    if (slots_[k].parameter == Parameter::sigma_scale) return theta[k];
  return options_.fixed_sigma_scale;
}

double InferenceProblem::tau(std::span<const double> theta) const {
  for (size_t k = 0; k < slots_.size(); ++k)
    if (slots_[k].parameter == Parameter::tau) return theta[k];
  return 0.0;
}

double InferenceProblem::eta_m(std::span<const double> theta) const {
  for (size_t k = 0; k < slots_.size(); ++k)
    if (slots_[k].parameter == Parameter::eta_m) return theta[k];
  return 0.0;
}

double InferenceProblem::eta_spread(std::span<const double> theta) const {
  for (size_t k = 0; k < slots_.size(); ++k)
    if (slots_[k].parameter == Parameter::eta_spread) return theta[k];
  return 0.0;
}

double InferenceProblem::recovery_log_likelihood(std::span<const double> theta,
                                                 int experiment) const {
  const Experiment& e = experiments_[experiment];
  if (e.kind != DataKind::recovery || !recovery_model_)
    throw std::invalid_argument("recovery_log_likelihood: experiment " +
                                std::to_string(experiment) + " holds no recovery data");
  const RecoveryCurve curve = recovery_model_->simulate(physical(theta, experiment));
  if (!curve.converged) return -kInf;
  const double spread = eta_spread(theta);
  const double l = spread != 0
                       ? recovery_spread_log_likelihood(curve, eta_m(theta), spread, *e.recovery,
                                                        options_.recovery_likelihood)
                       : rbc::recovery_log_likelihood(curve, eta_m(theta), *e.recovery,
                                                      options_.recovery_likelihood);
  return std::isfinite(l) ? l : -kInf;
}

ModelDiameters InferenceProblem::diameters_from_state(const WarmState& state) const {
  if (state.empty()) return {};
  const int nf = static_cast<int>(forwards_.front()->options().forces_pN.size());
  const int n = forwards_.front()->vertices();
  const size_t per_force = 3 * static_cast<size_t>(n) + 2;
  ModelDiameters d;
  for (int k = 0; k < nf; ++k) {
    const Positions x = Eigen::Map<const Positions>(state.data() + k * per_force, 3, n);
    const Diameters m = measure_diameters(x);
    d.axial_um.push_back(m.axial_um);
    d.transverse_um.push_back(m.transverse_um);
  }
  return d;
}

ModelDiameters InferenceProblem::experiment_diameters(const WarmState& state,
                                                      int experiment) const {
  if (state.size() != state_size()) return {};
  const Experiment& e = experiments_[experiment];
  if (e.kind == DataKind::recovery) return {};
  size_t offset = 0;
  for (int g = 0; g < e.group; ++g) offset += group_state_size(g);
  const int n = forwards_[e.group]->vertices();
  const size_t per_force = 3 * static_cast<size_t>(n) + 2;
  ModelDiameters d;
  for (int k : e.force_index) {
    const Positions x = Eigen::Map<const Positions>(state.data() + offset + k * per_force, 3, n);
    const Diameters m = measure_diameters(x);
    d.axial_um.push_back(m.axial_um);
    d.transverse_um.push_back(m.transverse_um);
  }
  return d;
}

ModelDiameters InferenceProblem::experiment_diameters(
    const std::vector<ModelDiameters>& group_diameters, int experiment) const {
  const Experiment& e = experiments_[experiment];
  if (e.kind == DataKind::recovery) return {};
  const ModelDiameters& g = group_diameters.at(static_cast<size_t>(e.group));
  ModelDiameters d;
  for (int k : e.force_index) {
    d.axial_um.push_back(g.axial_um.at(static_cast<size_t>(k)));
    d.transverse_um.push_back(g.transverse_um.at(static_cast<size_t>(k)));
  }
  return d;
}

double InferenceProblem::experiment_log_likelihood(std::span<const double> theta, int experiment,
                                                   const ModelDiameters& model) const {
  return gaussian_log_likelihood(experiments_[experiment].data, model, sigma_scale(theta),
                                 tau(theta));
}

double InferenceProblem::log_likelihood(std::span<const double> theta,
                                        const std::vector<ModelDiameters>& group_diameters) const {
  double l = 0;
  for (size_t e = 0; e < experiments_.size(); ++e) {
    if (experiments_[e].kind == DataKind::recovery) continue;
    const int ei = static_cast<int>(e);
    l += experiment_log_likelihood(theta, ei, experiment_diameters(group_diameters, ei));
  }
  return l;
}

Summary summarise(const std::string& name, const std::string& unit, const Eigen::VectorXd& v) {
  Summary s;
  s.name = name;
  s.unit = unit;
  s.mean = v.mean();
  s.sd = std::sqrt((v.array() - s.mean).square().sum() / std::max<Eigen::Index>(1, v.size() - 1));
  const std::vector<double> x(v.data(), v.data() + v.size());
  s.q05 = quantile(x, 0.05);
  s.q50 = quantile(x, 0.50);
  s.q95 = quantile(x, 0.95);
  return s;
}

Summary summarise_weighted(const std::string& name, const std::string& unit,
                           const Eigen::VectorXd& v, const Eigen::VectorXd& w) {
  Summary s;
  s.name = name;
  s.unit = unit;
  s.mean = w.dot(v);
  s.sd = std::sqrt(std::max(0.0, w.dot((v.array() - s.mean).square().matrix())));
  s.q05 = weighted_quantile(v, w, 0.05);
  s.q50 = weighted_quantile(v, w, 0.50);
  s.q95 = weighted_quantile(v, w, 0.95);
  return s;
}

LinearModuli sample_moduli(const ForwardParameters& p) {
  WlcParameters w;
  w.persistence_um = units::nm_to_um(p.persistence_nm);
  w.lmax_um = units::nm_to_um(p.lmax_nm);
  return closed_form_moduli(w, StericParameters{});
}

InferenceResult run_inference(const InferenceProblem& problem, const ProgressSink& progress,
                              const ExecutorFactory& factory) {
  return run_inference(problem, progress, factory, InferCheckpointing{});
}

InferenceResult run_inference(const InferenceProblem& problem, const ProgressSink& progress,
                              const ExecutorFactory& factory,
                              const InferCheckpointing& checkpointing) {
  const InferOptions& o = problem.options();
  // One BLAS thread for the run's duration only (forward_model.hpp, use_single_threaded_blas):
  // a Python session's numpy gets its threads back afterwards.
  const ScopedProcessBlasThreads single_blas(1);
  const Executor executor =
      factory ? factory(problem)
              : omp_executor(problem.prior(), problem.likelihood(), o.threads, o.sampler.cancel);
  TmcmcContinuation continuation;
  continuation.resume = checkpointing.resume;
  if (!checkpointing.path.empty()) {
    continuation.checkpoint = [inputs = posterior_inputs(problem),
                               path = checkpointing.path](const SamplerState& s) {
      write_stage_checkpoint(path, inputs, s);
    };
  }
  if (const SamplerState* s = checkpointing.resume) {
    std::ostringstream m;
    m << "resuming after stage " << s->stage << " (beta = " << std::setprecision(4)
      << s->schedule.back() << ", forward runs " << s->counts.runs << ")";
    report(progress, m.str());
  }
  const auto on_stage = [&](const StageInfo& s) {
    std::ostringstream m;
    m << "stage " << s.stage << (s.stage == 0 ? " (prior)" : "")
      << ": beta = " << std::setprecision(4) << s.beta << ", acceptance " << std::fixed
      << std::setprecision(2) << s.acceptance << ", distinct parents " << s.unique_fraction
      << ", forward runs " << s.forward_runs << ", elapsed " << std::setprecision(1) << s.elapsed_s
      << " s";
    report(progress, m.str());
  };
  TmcmcResult t;
  LaplaceIsResult lis;
  long long mode_runs = 0;
  const bool is = o.sampler_kind == SamplerKind::laplace_is;
  if (is) {
    if (checkpointing.resume)
      throw std::invalid_argument("--resume: a TMCMC checkpoint; expected --sampler tmcmc");
    lis = run_problem_laplace_is(problem, executor, progress, checkpointing, &mode_runs);
    t.samples = lis.samples;
    t.log_likelihood = lis.log_likelihood;
    t.states = lis.states;
    t.log_evidence = lis.log_evidence;
    t.log_evidence_sd = lis.log_evidence_sd;
    t.counts = lis.counts;
    t.counts.runs += mode_runs;
    t.wall_s = lis.wall_s;
    if (!(lis.ess >= o.min_effective_samples)) t.status = TmcmcStatus::low_ess;
    StageInfo s;  // one "stage": the importance samples at beta = 1
    s.beta = 1;
    s.forward_runs = t.counts.runs;
    s.elapsed_s = lis.wall_s;
    t.stages.push_back(s);
  } else {
    t = run_tmcmc(problem.likelihood(), problem.prior(), o.sampler, executor, on_stage,
                  continuation);
  }
  InferenceResult r;
  r.status = t.status;
  r.names = problem.names();
  r.units = problem.units();
  r.samples = t.samples;
  r.log_likelihood = t.log_likelihood;
  const int n = static_cast<int>(t.samples.rows()), d = static_cast<int>(t.samples.cols());
  r.mu_uN_per_m.resize(n);
  r.K_uN_per_m.resize(n);
  const int experiments = static_cast<int>(problem.experiments().size());
  // Per experiment and force: the samples' model diameters.
  std::vector<std::vector<std::vector<double>>> da(experiments), dt(experiments);
  for (int e = 0; e < experiments; ++e) {
    da[e].resize(problem.experiments()[e].data.size());
    dt[e].resize(problem.experiments()[e].data.size());
  }
  for (int i = 0; i < n; ++i) {
    std::vector<double> theta(d);
    for (int k = 0; k < d; ++k) theta[k] = t.samples(i, k);
    const LinearModuli m = sample_moduli(problem.physical(theta));
    r.mu_uN_per_m(i) = m.mu_pN_per_um * units::uN_per_m_per_pN_per_um;
    r.K_uN_per_m(i) = m.K_pN_per_um * units::uN_per_m_per_pN_per_um;
    for (int e = 0; e < experiments; ++e) {
      const ModelDiameters md = problem.experiment_diameters(t.states[i], e);
      for (int k = 0; k < static_cast<int>(md.axial_um.size()); ++k) {
        da[e][k].push_back(md.axial_um[k]);
        dt[e][k].push_back(md.transverse_um[k]);
      }
    }
  }
  for (int k = 0; k < d; ++k)
    r.parameters.push_back(summarise(r.names[k], r.units[k], t.samples.col(k)));
  r.mu = summarise("mu", "uN/m", r.mu_uN_per_m);
  r.K = summarise("K", "uN/m", r.K_uN_per_m);
  if (is) {
    // The summaries from the weighted draws themselves (resampling only adds noise).
    const int s = static_cast<int>(lis.draws.rows());
    Eigen::VectorXd mu(s), kk(s);
    for (int i = 0; i < s; ++i) {
      std::vector<double> theta(d);
      for (int k = 0; k < d; ++k) theta[k] = lis.draws(i, k);
      const LinearModuli m = sample_moduli(problem.physical(theta));
      mu(i) = m.mu_pN_per_um * units::uN_per_m_per_pN_per_um;
      kk(i) = m.K_pN_per_um * units::uN_per_m_per_pN_per_um;
    }
    for (int k = 0; k < d; ++k)
      r.parameters[k] = summarise_weighted(r.names[k], r.units[k], lis.draws.col(k), lis.weights);
    r.mu = summarise_weighted("mu", "uN/m", mu, lis.weights);
    r.K = summarise_weighted("K", "uN/m", kk, lis.weights);
    r.sampler = to_string(SamplerKind::laplace_is);
    r.ess = lis.ess;
    r.is_rounds = o.is_rounds;
    r.round_ess = lis.round_ess;
    r.mode.assign(lis.mode_theta.data(), lis.mode_theta.data() + d);
    r.newton_steps = lis.newton_steps;
    r.gradient_evaluations = lis.gradient_evaluations;
  }
  r.log_evidence = t.log_evidence;
  r.log_evidence_sd = t.log_evidence_sd;
  r.counts = t.counts;
  r.stages = t.stages;
  r.wall_s = t.wall_s;
  r.data = problem.data();
  for (int e = 0; e < experiments; ++e) {
    const Experiment& x = problem.experiments()[e];
    InferenceResult::ExperimentFit f;
    f.path = x.path;
    f.stem = x.stem;
    f.kind = to_string(x.kind);
    f.digest = data_file_digest(x.path);
    f.data = x.data;
    for (int k = 0; k < x.data.size(); ++k) {
      if (da[e][k].empty()) continue;
      f.axial_q05.push_back(quantile(da[e][k], 0.05));
      f.axial_q50.push_back(quantile(da[e][k], 0.50));
      f.axial_q95.push_back(quantile(da[e][k], 0.95));
      f.transverse_q05.push_back(quantile(dt[e][k], 0.05));
      f.transverse_q50.push_back(quantile(dt[e][k], 0.50));
      f.transverse_q95.push_back(quantile(dt[e][k], 0.95));
    }
    r.experiments.push_back(std::move(f));
  }
  {
    const auto& f = r.experiments.front();
    r.axial_q05 = f.axial_q05;
    r.axial_q50 = f.axial_q50;
    r.axial_q95 = f.axial_q95;
    r.transverse_q05 = f.transverse_q05;
    r.transverse_q50 = f.transverse_q50;
    r.transverse_q95 = f.transverse_q95;
  }
  r.prior_lower = problem.prior().lower;
  r.prior_upper = problem.prior().upper;
  r.method = o.method.name();
  r.data_file = o.data_path();
  r.vertices = problem.forward().vertices();
  r.elements = problem.forward().elements();
  r.samples_per_stage = is ? o.is_samples : o.sampler.samples;
  r.seed = o.sampler.seed;
  // The threads the forward runs used (the executor's count; MPI: per rank).
  r.threads = factory ? o.threads : (o.threads > 0 ? o.threads : omp_get_max_threads());
  r.resumed_from_stage = checkpointing.resume ? checkpointing.resume->stage : -1;
  return r;
}

InferenceResult run_inference(const InferOptions& options, const ProgressSink& progress) {
  const InferenceProblem problem(options);
  return run_inference(problem, progress);
}

std::string sigma_text(const DiameterData& d) {
  std::ostringstream s;
  s << std::setprecision(4) << "the file's error bars";
  if (d.declared_extra_uncertainty_um > 0)
    s << " (+) " << d.declared_extra_uncertainty_um << " um declared";
  if (d.added_extra_uncertainty_um > 0) s << " (+) " << d.added_extra_uncertainty_um << " um added";
  if (d.declared_extra_uncertainty_um > 0 && d.added_extra_uncertainty_um > 0)
    s << " (extra " << d.extra_uncertainty_um() << " um)";
  if (d.declared_extra_uncertainty_um > 0 || d.added_extra_uncertainty_um > 0)
    s << ", in quadrature";
  return s.str();
}

std::string inference_json(const InferenceResult& r) {
  using nlohmann::json;
  auto summary = [](const Summary& s) {
    return json{{"unit", s.unit}, {"mean", s.mean}, {"sd", s.sd},
                {"q05", s.q05},   {"q50", s.q50},   {"q95", s.q95}};
  };
  json j;
  j["status"] = to_string(r.status);
  j["method"] = r.method;
  j["data_file"] = r.data_file;
  j["vertices"] = r.vertices;
  j["elements"] = r.elements;
  j["samples_per_stage"] = r.samples_per_stage;
  j["seed"] = r.seed;
  json params = json::object();
  for (size_t k = 0; k < r.parameters.size(); ++k) {
    params[r.parameters[k].name] = summary(r.parameters[k]);
    if (k < r.prior_lower.size())
      params[r.parameters[k].name]["prior"] = {r.prior_lower[k], r.prior_upper[k]};
  }
  j["parameters"] = params;
  j["derived"] = {{"mu", summary(r.mu)}, {"K", summary(r.K)}};
  j["log_evidence"] = r.log_evidence;
  j["log_evidence_sd"] = r.log_evidence_sd;
  j["sampler"] = r.sampler;
  if (r.sampler == "laplace-is") {
    j["log_evidence_error_estimate"] =
        "delta method: sd of the importance weights / (sqrt(samples) x their mean) "
        "(calibrate/laplace_is.hpp)";
    j["ess"] = r.ess;
    j["is_rounds"] = r.is_rounds;
    j["round_ess"] = r.round_ess;
    json mode = json::object();  // natural units, those of "parameters"
    for (size_t k = 0; k < r.mode.size() && k < r.names.size(); ++k) mode[r.names[k]] = r.mode[k];
    j["laplace"] = {{"mode", mode},
                    {"newton_steps", r.newton_steps},
                    {"gradient_evaluations", r.gradient_evaluations}};
  } else {
    j["log_evidence_error_estimate"] =
        "scatter of the independent islands' log-evidence / sqrt(islands) (calibrate/tmcmc.hpp)";
  }
  j["stages"] = static_cast<int>(r.stages.size()) - 1;
  json stages = json::array();
  for (const auto& s : r.stages)
    stages.push_back({{"stage", s.stage},
                      {"beta", s.beta},
                      {"cov", s.cov},
                      {"acceptance", s.acceptance},
                      {"distinct_parents", s.unique_fraction},
                      {"forward_runs", s.forward_runs}});
  j["stage_log"] = stages;
  j["forward_runs"] = {{"made", r.counts.runs},
                       {"retried", r.counts.retried},
                       {"failed", r.counts.failed},
                       {"symmetry_broken", r.counts.symmetry_broken}};
  json pred = json::array();
  for (size_t k = 0; k < r.axial_q50.size(); ++k)
    pred.push_back(
        {{"force_pN", r.data.force_pN[k]},
         {"axial_um", {r.axial_q05[k], r.axial_q50[k], r.axial_q95[k]}},
         {"transverse_um", {r.transverse_q05[k], r.transverse_q50[k], r.transverse_q95[k]}}});
  j["predictive_q05_q50_q95"] = pred;
  // The data as the likelihood saw them (total sigma = error bar, declared and added extra
  // uncertainty in quadrature, before sigma-scale), so a reader of the summary can check the
  // fit alone.
  json data = json::array();
  for (int k = 0; k < r.data.size(); ++k)
    data.push_back({{"force_pN", r.data.force_pN[k]},
                    {"axial_um", r.data.axial_um[k]},
                    {"axial_sigma_um", r.data.axial_sigma_um[k]},
                    {"transverse_um", r.data.transverse_um[k]},
                    {"transverse_sigma_um", r.data.transverse_sigma_um[k]},
                    {"transverse_used", r.data.transverse_used[k] != 0}});
  j["data"] = data;
  // Every experiment: file, content digest, sigma, and (several files) its own data and
  // predictive band.
  json sets = json::array();
  if (r.experiments.empty())
    sets.push_back({{"file", r.data_file},
                    {"name", r.data.name},
                    {"declared_extra_uncertainty_um", r.data.declared_extra_uncertainty_um},
                    {"added_extra_uncertainty_um", r.data.added_extra_uncertainty_um},
                    {"extra_uncertainty_um", r.data.extra_uncertainty_um()},
                    {"sigma", sigma_text(r.data)}});
  for (const auto& e : r.experiments) {
    json set = {{"file", e.path},
                {"stem", e.stem},
                {"kind", e.kind},
                {"contents", e.digest},
                {"name", e.data.name},
                {"declared_extra_uncertainty_um", e.data.declared_extra_uncertainty_um},
                {"added_extra_uncertainty_um", e.data.added_extra_uncertainty_um},
                {"extra_uncertainty_um", e.data.extra_uncertainty_um()},
                {"sigma", sigma_text(e.data)}};
    if (r.experiments.size() > 1) {
      json points = json::array();
      for (int k = 0; k < e.data.size(); ++k) {
        json pt = {{"force_pN", e.data.force_pN[k]},
                   {"axial_um", e.data.axial_um[k]},
                   {"axial_sigma_um", e.data.axial_sigma_um[k]},
                   {"transverse_um", e.data.transverse_um[k]},
                   {"transverse_sigma_um", e.data.transverse_sigma_um[k]},
                   {"transverse_used", e.data.transverse_used[k] != 0}};
        if (static_cast<size_t>(k) < e.axial_q50.size()) {
          pt["predictive_axial_um"] = {e.axial_q05[k], e.axial_q50[k], e.axial_q95[k]};
          pt["predictive_transverse_um"] = {e.transverse_q05[k], e.transverse_q50[k],
                                            e.transverse_q95[k]};
        }
        points.push_back(pt);
      }
      set["points"] = points;
    }
    sets.push_back(set);
  }
  j["data_sets"] = sets;
  if (!r.predictions.is_null()) j["predictions"] = r.predictions;
  j["command"] = r.command;
  if (r.record.is_object())
    for (const auto& [key, value] : r.record.items())
      if (key != "command") j[key] = value;  // "command" stays the command line
  j["timing"] = {{"wall_s", r.wall_s}, {"threads", r.threads}, {"ranks", r.ranks}};
  if (r.resumed_from_stage >= 0) j["timing"]["resumed_from_stage"] = r.resumed_from_stage;
  return j.dump(2);
}

}  // namespace rbc
