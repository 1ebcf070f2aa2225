// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer --sampler laplace-is`: the Laplace-IS sampler (calibrate/laplace_is.hpp) on the
// calibration's likelihood, with the gradient through the continuum forward model's
// sensitivities (calibrate/sensitivity.hpp) and the Gauss-Newton information built from them.
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "calibrate/infer.hpp"
#include "calibrate/laplace_is.hpp"
#include "calibrate/sensitivity.hpp"

namespace rbc {

LaplaceIsResult run_problem_laplace_is(const InferenceProblem& problem, const Executor& executor,
                                       const ProgressSink& progress, long long* forward_runs_out,
                                       long long* sensitivity_solves_out) {
  const InferOptions& o = problem.options();
  const StretchSensitivity sensitivity(problem.forward().options());
  const DiameterData& data = problem.data();
  const int d = static_cast<int>(o.parameters.size());
  long long forward_runs = 0, sensitivity_solves = 0;
  const GradientTarget target = [&](const Eigen::VectorXd& theta, const WarmState& warm) {
    GradientPoint p;
    const std::vector<double> t(theta.data(), theta.data() + d);
    const LikelihoodGradient g = log_likelihood_and_gradient(problem, sensitivity, t, warm);
    ++forward_runs;
    if (g.failed) return p;
    ++sensitivity_solves;
    p.log_likelihood = g.log_likelihood;
    p.gradient = Eigen::Map<const Eigen::VectorXd>(g.gradient.data(), d);
    if (!p.gradient.allFinite()) return p;
    // Gauss-Newton information of the whitened residuals: sum over the Gaussian terms of
    // (dD/dtheta_k)(dD/dtheta_l) / (c sigma)^2; the sigma scale c adds 2 / c^2 per term on its
    // own diagonal (the expected information of a scale), uncoupled from the rest.
    const double c = problem.sigma_scale(t);
    std::vector<int> column(d, -1);
    for (int k = 0; k < d; ++k)
      for (size_t j = 0; j < g.sensitivities.parameters.size(); ++j)
        if (g.sensitivities.parameters[j] == o.parameters[k]) column[k] = static_cast<int>(j);
    Eigen::MatrixXd info = Eigen::MatrixXd::Zero(d, d);
    for (int f = 0; f < data.size(); ++f) {
      const ForceSensitivity& s = g.sensitivities.forces[f];
      Eigen::VectorXd ja = Eigen::VectorXd::Zero(d), jt = Eigen::VectorXd::Zero(d);
      for (int k = 0; k < d; ++k)
        if (column[k] >= 0) {
          ja(k) = s.d_axial[column[k]] / (c * data.axial_sigma_um[f]);
          jt(k) = s.d_transverse[column[k]] / (c * data.transverse_sigma_um[f]);
        }
      info += ja * ja.transpose();
      if (data.transverse_used[f]) info += jt * jt.transpose();
    }
    for (int k = 0; k < d; ++k)
      if (o.parameters[k] == Parameter::sigma_scale) info(k, k) += 2.0 * data.terms() / (c * c);
    p.information = info;
    p.state = g.state;
    p.ok = info.allFinite();
    return p;
  };
  LaplaceIsOptions lo;
  lo.samples = o.is_samples;
  lo.seed = o.sampler.seed;
  report(progress, "laplace-is: mode search (damped Gauss-Newton in logit coordinates)");
  LaplaceIsResult r = run_laplace_is(target, problem.likelihood(), problem.prior(), lo, executor);
  std::ostringstream m;
  m << "laplace-is: " << r.newton_steps << " Newton steps, " << sensitivity_solves
    << " gradient evaluations; " << lo.samples << " importance samples, ESS " << std::fixed
    << std::setprecision(1) << r.ess << ", log evidence " << std::setprecision(3) << r.log_evidence
    << " +- " << r.log_evidence_sd;
  report(progress, m.str());
  if (forward_runs_out) *forward_runs_out = forward_runs;
  if (sensitivity_solves_out) *sensitivity_solves_out = sensitivity_solves;
  return r;
}

}  // namespace rbc
