// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc infer --sampler laplace-is`: the Laplace-IS sampler (calibrate/laplace_is.hpp) on the
// calibration's likelihood, with the gradient through the continuum forward model's
// sensitivities (calibrate/sensitivity.hpp) and the Gauss-Newton information built from them;
// recovery data add the release scene's term with its gradient and Gauss-Newton information
// (calibrate/recovery_likelihood.hpp recovery_gradient_and_information). With a checkpoint
// path the run's state goes to a laplace-is checkpoint (calibrate/laplace_is_checkpoint.hpp)
// with the mode search's work counted here, and a resumed run starts from one.
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "calibrate/infer.hpp"
#include "calibrate/laplace_is.hpp"
#include "calibrate/laplace_is_checkpoint.hpp"
#include "calibrate/sensitivity.hpp"

namespace rbc {

LaplaceIsResult run_problem_laplace_is(const InferenceProblem& problem, const Executor& executor,
                                       const ProgressSink& progress, long long* forward_runs_out,
                                       long long* sensitivity_solves_out) {
  return run_problem_laplace_is(problem, executor, progress, InferCheckpointing{}, forward_runs_out,
                                sensitivity_solves_out);
}

LaplaceIsResult run_problem_laplace_is(const InferenceProblem& problem, const Executor& executor,
                                       const ProgressSink& progress,
                                       const InferCheckpointing& checkpointing,
                                       long long* forward_runs_out,
                                       long long* sensitivity_solves_out) {
  const InferOptions& o = problem.options();
  const StretchSensitivity sensitivity(problem.forward().options());
  const int d = static_cast<int>(problem.slots().size());
  long long forward_runs = 0, sensitivity_solves = 0, recovery_trajectories = 0, evaluations = 0;
  const GradientTarget target = [&](const Eigen::VectorXd& theta, const WarmState& warm) {
    GradientPoint p;
    const std::vector<double> t(theta.data(), theta.data() + d);
    const LikelihoodGradient g = log_likelihood_and_gradient(problem, sensitivity, t, warm);
    forward_runs += problem.groups();  // one run per forward-run group
    recovery_trajectories += g.recovery_trajectories;
    {  // one line per evaluation: a mode search with release trajectories takes minutes
      std::ostringstream m;
      m << "laplace-is: mode search, gradient evaluation " << ++evaluations << ": ";
      if (g.failed)
        m << "forward run failed";
      else
        m << "log L " << std::fixed << std::setprecision(3) << g.log_likelihood;
      if (recovery_trajectories > 0)
        m << " (" << recovery_trajectories << " release trajectories so far)";
      report(progress, m.str());
    }
    if (g.failed) return p;
    ++sensitivity_solves;
    p.log_likelihood = g.log_likelihood;
    p.gradient = Eigen::Map<const Eigen::VectorXd>(g.gradient.data(), d);
    if (!p.gradient.allFinite()) return p;
    // Gauss-Newton information of every experiment's Gaussian blocks (J' Sigma^-1 J for the
    // physical slots; the expected information of the sigma scale and tau, uncoupled from them:
    // calibrate/sensitivity.hpp, LikelihoodGradient::information).
    const Eigen::MatrixXd& info = g.information;
    p.information = info;
    p.state = g.state;
    p.ok = info.allFinite();
    return p;
  };
  LaplaceIsOptions lo;
  lo.samples = o.is_samples;
  lo.rounds = o.is_rounds;
  lo.seed = o.sampler.seed;
  lo.cancel = o.sampler.cancel;
  LaplaceIsContinuation continuation;
  if (const LaplaceIsCheckpoint* c = checkpointing.laplace_is_resume) {
    continuation.resume = &c->state;
    forward_runs = c->mode_forward_runs;
    sensitivity_solves = c->sensitivity_solves;
    recovery_trajectories = c->recovery_trajectories;
    evaluations = c->state.gradient_evaluations;
    report(progress, "laplace-is: resuming from the checkpoint (" +
                         laplace_is_position(c->state, lo.samples) + ")");
  } else {
    report(progress, "laplace-is: mode search (damped Gauss-Newton in logit coordinates)");
  }
  if (!checkpointing.path.empty()) {
    continuation.checkpoint = [&, inputs = laplace_is_inputs(problem)](const LaplaceIsState& s) {
      LaplaceIsCheckpoint c;
      c.inputs = inputs;
      c.state = s;
      c.mode_forward_runs = forward_runs;
      c.sensitivity_solves = sensitivity_solves;
      c.recovery_trajectories = recovery_trajectories;
      write_laplace_is_checkpoint(checkpointing.path, c, lo.samples);
      const std::string where = laplace_is_position(s, lo.samples);
      if (s.mode_found && s.draws_done > 0) report(progress, "laplace-is: " + where);
      if (checkpointing.on_checkpoint) checkpointing.on_checkpoint(where);
    };
  }
  LaplaceIsResult r =
      run_laplace_is(target, problem.likelihood(), problem.prior(), lo, executor, continuation);
  std::ostringstream m;
  m << "laplace-is: " << r.newton_steps << " Newton steps, " << sensitivity_solves
    << " gradient evaluations";
  if (recovery_trajectories > 0) m << " (" << recovery_trajectories << " release trajectories)";
  m << "; " << lo.samples << " importance samples";
  if (lo.rounds > 1) m << " in " << lo.rounds << " rounds";
  m << ", ESS " << std::fixed << std::setprecision(1) << r.ess << ", log evidence "
    << std::setprecision(3) << r.log_evidence << " +- " << r.log_evidence_sd;
  report(progress, m.str());
  if (forward_runs_out) *forward_runs_out = forward_runs;
  if (sensitivity_solves_out) *sensitivity_solves_out = sensitivity_solves;
  return r;
}

}  // namespace rbc
