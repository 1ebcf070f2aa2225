// SPDX-License-Identifier: GPL-3.0-or-later
// Bayesian calibration (calibrate/infer.hpp): the inference problem (data, forward model, prior
// box, the likelihood `rbc infer` samples) and the posterior run, as `rbc infer` sets them up.
#include <nlohmann/json.hpp>

#include "calibrate/infer.hpp"
#include "calibrate/predictive.hpp"
#include "calibrate/recovery_prediction.hpp"
#include "calibrate/sensitivity.hpp"
#include "common.hpp"

namespace rbc::py_bind {

namespace {

/// InferOptions from the Python arguments (natural units, the CLI's names and defaults).
InferOptions infer_options(const std::vector<std::string>& parameters, const py::dict& priors,
                           const std::string& method, const std::string& data_file,
                           double extra_uncertainty_um, const py::dict& fixed,
                           double fixed_sigma_scale, int samples, int chain_length,
                           double target_cov, double proposal_scale, unsigned long long seed,
                           int threads, const std::string& sampler, int is_samples, int is_rounds) {
  InferOptions o;
  if (sampler == "laplace-is")
    o.sampler_kind = SamplerKind::laplace_is;
  else if (sampler == "tmcmc")
    o.sampler_kind = SamplerKind::tmcmc;
  else
    throw py::value_error("sampler '" + sampler + "': expected 'laplace-is' or 'tmcmc'");
  o.is_samples = is_samples;
  o.is_rounds = is_rounds;
  o.data_file = data_file;
  o.method = parse_method(method);
  o.parameters.clear();
  for (const auto& p : parameters) o.parameters.push_back(parameter_from_string(p));
  for (const auto& [k, v] : priors) {
    const auto box = v.cast<std::pair<double, double>>();
    const std::string name = k.cast<std::string>();
    finite("priors['" + name + "'] lower bound", box.first);
    finite("priors['" + name + "'] upper bound", box.second);
    PriorRange r;
    r.parameter = parameter_from_string(name);
    r.lower = box.first;
    r.upper = box.second;
    o.priors.push_back(r);
  }
  o.extra_uncertainty_um = finite("extra_uncertainty_um", extra_uncertainty_um);
  for (const auto& [k, v] : fixed) {
    const std::string name = k.cast<std::string>();
    const double x = finite("fixed['" + name + "']", v.cast<double>());
    if (name == "persistence_nm")
      o.fixed.persistence_nm = x;
    else if (name == "lmax_nm")
      o.fixed.lmax_nm = x;
    else if (name == "kappa_J")
      o.fixed.kappa_J = x;
    else if (name == "contact_fraction")
      o.fixed.contact_fraction = x;
    else
      throw py::value_error("fixed parameter '" + name +
                            "' is not one of persistence_nm, lmax_nm, kappa_J, contact_fraction");
  }
  o.fixed_sigma_scale = finite("fixed_sigma_scale", fixed_sigma_scale);
  o.sampler.samples = samples;
  o.sampler.chain_length = chain_length;
  o.sampler.target_cov = finite("target_cov", target_cov);
  o.sampler.proposal_scale = finite("proposal_scale", proposal_scale);
  o.sampler.seed = seed;
  o.threads = threads;
  o.validate();  // std::invalid_argument -> ValueError naming the value
  return o;
}

std::vector<double> theta_arg(const InferenceProblem& p, const py::handle& theta) {
  const auto t = theta.cast<std::vector<double>>();
  if (static_cast<int>(t.size()) != p.prior().dimension())
    throw py::value_error("theta must have " + std::to_string(p.prior().dimension()) + " values (" +
                          std::to_string(t.size()) + " given)");
  require_finite("theta", t.data(), t.size());
  return t;
}

py::array_t<double> to_array(const std::vector<double>& v) {
  return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
}

}  // namespace

void bind_infer(py::module_& m) {
  py::class_<InferenceProblem, std::shared_ptr<InferenceProblem>>(
      m, "InferenceProblem",
      "The calibration problem of `rbc infer` (MODEL.md section 7): force-diameter data, the "
      "forward model (method 'continuum:ORDER:ELEMENTS' or 'discrete:N'), uniform prior boxes "
      "of the inferred parameters (names of `rbc infer --params`: persistence, lmax, kappa, "
      "contact-fraction, sigma-scale; natural units nm, nm, J, 1, 1) and its Gaussian "
      "likelihood. Defaults are the CLI's.")
      .def(py::init([](const std::vector<std::string>& parameters, const py::dict& priors,
                       const std::string& method, const std::string& data_file,
                       double extra_uncertainty_um, const py::dict& fixed, double fixed_sigma_scale,
                       int samples, int chain_length, double target_cov, double proposal_scale,
                       unsigned long long seed, int threads, const std::string& sampler,
                       int is_samples, int is_rounds) {
             const InferOptions o =
                 infer_options(parameters, priors, method, data_file, extra_uncertainty_um, fixed,
                               fixed_sigma_scale, samples, chain_length, target_cov, proposal_scale,
                               seed, threads, sampler, is_samples, is_rounds);
             return run_released(nullptr, [&] { return std::make_shared<InferenceProblem>(o); });
           }),
           py::kw_only(),
           py::arg("parameters") = std::vector<std::string>{"persistence", "lmax", "sigma-scale"},
           py::arg("priors") = py::dict(),
           py::arg("method") = "continuum:2:" + std::to_string(InferOptions{}.method.resolution),
           py::arg("data_file") = "", py::arg("extra_uncertainty_um") = 0.0,
           py::arg("fixed") = py::dict(), py::arg("fixed_sigma_scale") = 1.0,
           py::arg("samples") = InferOptions::default_sampler().samples,
           py::arg("chain_length") = InferOptions::default_sampler().chain_length,
           py::arg("target_cov") = InferOptions::default_sampler().target_cov,
           py::arg("proposal_scale") = InferOptions::default_sampler().proposal_scale,
           py::arg("seed") = 1, py::arg("threads") = 0,
           py::arg("sampler") = to_string(InferOptions{}.sampler_kind),
           py::arg("is_samples") = InferOptions{}.is_samples,
           py::arg("is_rounds") = InferOptions{}.is_rounds,
           "priors: {name: (lower, upper)} overriding the defaults; fixed: values of the physical "
           "parameters not inferred ({'kappa_J': 3e-19, ...}); sampler: 'laplace-is' (is_samples "
           "importance samples in is_rounds adaptation rounds) or 'tmcmc' (samples, chain_length, "
           "target_cov, proposal_scale), "
           "as `rbc infer --sampler`.")
      .def_property_readonly("names", [](const InferenceProblem& p) { return p.names(); })
      .def_property_readonly("units", [](const InferenceProblem& p) { return p.units(); })
      .def_property_readonly("prior_lower",
                             [](const InferenceProblem& p) { return to_array(p.prior().lower); })
      .def_property_readonly("prior_upper",
                             [](const InferenceProblem& p) { return to_array(p.prior().upper); })
      .def_property_readonly("data",
                             [](const InferenceProblem& p) {
                               const DiameterData& d = p.data();
                               py::dict out;
                               out["force_pN"] = to_array(d.force_pN);
                               out["axial_um"] = to_array(d.axial_um);
                               out["axial_sigma_um"] = to_array(d.axial_sigma_um);
                               out["transverse_um"] = to_array(d.transverse_um);
                               out["transverse_sigma_um"] = to_array(d.transverse_sigma_um);
                               out["name"] = d.name;
                               out["declared_extra_uncertainty_um"] =
                                   d.declared_extra_uncertainty_um;
                               out["added_extra_uncertainty_um"] = d.added_extra_uncertainty_um;
                               return out;
                             })
      .def(
          "log_likelihood",
          [](const InferenceProblem& p, const py::handle& theta, const py::object& warm) {
            const std::vector<double> t = theta_arg(p, theta);
            WarmState w;
            if (!warm.is_none()) {
              w = warm.cast<std::vector<double>>();
              require_finite("warm", w.data(), w.size());
            }
            if (!p.prior().contains(t)) return -std::numeric_limits<double>::infinity();
            const LikelihoodValue v =
                run_released(nullptr, [&] { return p.likelihood().evaluate(t, w, nullptr); });
            return v.log_likelihood;
          },
          py::arg("theta"), py::arg("warm") = py::none(),
          "log L(theta) of `rbc infer` (-inf outside the prior box or for a failed forward run); "
          "warm: a state from forward_state() to start the forward solves from (same result to "
          "the solver tolerance, faster).")
      .def(
          "forward_state",
          [](const InferenceProblem& p, const py::handle& theta) {
            const std::vector<double> t = theta_arg(p, theta);
            WarmState state;
            run_released(nullptr, [&] { p.likelihood().evaluate(t, {}, &state); });
            return to_array(state);
          },
          py::arg("theta"),
          "The forward model's equilibria at theta (per force: 3N positions and two multipliers), "
          "a warm start for log_likelihood.")
      .def(
          "log_likelihood_and_gradient",
          [](const InferenceProblem& p, const py::handle& theta, const py::object& warm) {
            const std::vector<double> t = theta_arg(p, theta);
            WarmState w;
            if (!warm.is_none()) {
              w = warm.cast<std::vector<double>>();
              require_finite("warm", w.data(), w.size());
            }
            const LikelihoodGradient g = run_released(nullptr, [&] {
              // The sensitivities' rest mesh is the forward model's, rebuilt per call.
              const StretchSensitivity sensitivity(p.forward().options());
              return log_likelihood_and_gradient(p, sensitivity, t, w);
            });
            if (g.failed)
              return py::make_tuple(-std::numeric_limits<double>::infinity(), py::none());
            return py::make_tuple(g.log_likelihood, to_array(g.gradient));
          },
          py::arg("theta"), py::arg("warm") = py::none(),
          "(log L, d log L / d theta) at theta (natural units; the gradient in the same units), "
          "by the implicit function theorem on the forward model's constrained equilibria "
          "(calibrate/sensitivity.hpp; continuum forward model only). The prior box is not "
          "applied; (-inf, None) for a failed forward run.")
      .def(
          "identifiability",
          [](const InferenceProblem& p, const py::handle& theta,
             const std::vector<double>& candidate_forces_pN) {
            const std::vector<double> t = theta_arg(p, theta);
            require_finite("candidate_forces_pN", candidate_forces_pN.data(),
                           candidate_forces_pN.size());
            const IdentifiabilityReport r =
                run_released(nullptr, [&] { return identifiability(p, t, candidate_forces_pN); });
            return py::module_::import("json").attr("loads")(r.to_json().dump());
          },
          py::arg("theta"), py::arg("candidate_forces_pN") = std::vector<double>{},
          "The identifiability report of `rbc infer` (DIR/identifiability.json's fields) at "
          "theta: the Fisher information's parameter combinations and their precision, and the "
          "candidate forces ranked by expected information gain.");

  m.def(
      "_infer",
      [](std::shared_ptr<InferenceProblem> problem, py::object cancel, py::object progress,
         const std::vector<std::string>& predict, int predict_draws, int predict_recovery_draws) {
        if (predict_draws < 0)
          throw std::invalid_argument("predict_draws must be >= 0 (0: every sample), got " +
                                      std::to_string(predict_draws));
        if (predict_recovery_draws < 0)
          throw std::invalid_argument(
              "predict_recovery_draws must be >= 0 (0: every sample), got " +
              std::to_string(predict_recovery_draws));
        // run_inference takes the sampler options (and their cancel hook, polled between
        // stages) from the problem: a copy of it is built with the hook (data, mesh; no solve).
        const auto cb = make_callbacks(std::move(cancel), std::move(progress));
        InferOptions o = problem->options();
        o.sampler.cancel = make_cancel_check(cb);
        const ProgressSink sink = make_progress_sink(cb);
        const InferenceResult r = run_released(cb, [&] {
          const InferenceProblem p(o);
          // Held-out files, stretch (calibrate/predictive.hpp) or recovery data
          // (calibrate/recovery_prediction.hpp, by the file's header): read and checked before
          // any forward run.
          std::vector<std::unique_ptr<PredictionProblem>> held_out;
          std::vector<std::unique_ptr<RecoveryPredictionProblem>> recovery;
          for (const std::string& f : predict) {
            const bool is_recovery = [&] {
              try {
                return detect_data_kind(f) == DataKind::recovery;
              } catch (const std::exception&) {
                return false;  // the stretch reader names what is wrong with the file
              }
            }();
            if (is_recovery)
              recovery.push_back(std::make_unique<RecoveryPredictionProblem>(p, f));
            else
              held_out.push_back(std::make_unique<PredictionProblem>(p, f));
          }
          InferenceResult res = run_inference(p, sink);
          std::vector<HeldOutPrediction> predictions;
          for (const auto& h : held_out)
            predictions.push_back(predict_held_out(*h, res, predict_draws, {}, sink));
          if (!predictions.empty()) res.predictions = predictions_json(predictions);
          for (const auto& r : recovery) {
            const RecoveryPrediction rp =
                predict_recovery(*r, res, predict_recovery_draws, {}, sink);
            if (res.predictions.is_null()) res.predictions = nlohmann::json::array();
            res.predictions.push_back(recovery_prediction_json(rp));
          }
          return res;
        });
        py::dict out = py::module_::import("json").attr("loads")(inference_json(r));
        // (S, P) C-contiguous: a view of the transposed (column-major P x S) copy.
        out["samples"] = owning_rows(Eigen::MatrixXd(r.samples.transpose()));
        out["log_likelihood_samples"] = owning_vector(Eigen::VectorXd(r.log_likelihood));
        out["mu_samples_uN_per_m"] = owning_vector(Eigen::VectorXd(r.mu_uN_per_m));
        out["K_samples_uN_per_m"] = owning_vector(Eigen::VectorXd(r.K_uN_per_m));
        py::list stages;
        for (const StageInfo& s : r.stages) {
          py::dict d;
          d["stage"] = s.stage;
          d["beta"] = s.beta;
          d["cov"] = s.cov;
          d["log_mean_weight"] = s.log_mean_weight;
          d["acceptance"] = s.acceptance;
          d["unique_fraction"] = s.unique_fraction;
          d["forward_runs"] = s.forward_runs;
          stages.append(d);
        }
        out["stage_info"] = stages;
        out["converged"] = r.status == TmcmcStatus::converged;
        out["status_text"] = to_string(r.status);
        return out;
      },
      py::arg("problem"), py::arg("cancel"), py::arg("progress"),
      py::arg("predict") = std::vector<std::string>{},
      py::arg("predict_draws") = kDefaultPredictiveDraws,
      py::arg("predict_recovery_draws") = kDefaultRecoveryPredictiveDraws);
}

}  // namespace rbc::py_bind
