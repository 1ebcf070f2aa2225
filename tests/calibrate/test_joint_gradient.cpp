// SPDX-License-Identifier: GPL-3.0-or-later
// The likelihood gradient with recovery data (calibrate/sensitivity.hpp
// log_likelihood_and_gradient with the release scene's term, calibrate/recovery_likelihood.hpp
// recovery_gradient_and_information): against central differences of the sampler's
// log-likelihood, its Gauss-Newton information in eta_m against the curvature of log L, the same
// bits at 1 and 2 threads; and the joint stretch + recovery posterior by laplace-is on data
// generated inside the test at parameters the inference is not told.
#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "calibrate/forward_model.hpp"
#include "calibrate/infer.hpp"
#include "calibrate/recovery_likelihood.hpp"
#include "calibrate/sensitivity.hpp"
#include "core/units.hpp"
#include "test_output.hpp"

namespace rbc {
namespace joint_gradient_test {
namespace {

/// The truth of both data sets (not given to the inference).
ForwardParameters truth_parameters() {
  ForwardParameters t;
  t.persistence_nm = 9.0;
  t.lmax_nm = 190.0;
  return t;
}
constexpr double kTruthEta = 0.93;  // pN s/um

/// A stretch table of the model's diameters (continuum:2:200) at `truth` plus Gaussian noise of
/// sd noise_um (seeded); error bars noise_um.
std::string stretch_table(const std::filesystem::path& dir, const ForwardParameters& truth,
                          double noise_um, unsigned seed) {
  ForwardOptions fo;
  fo.method = parse_method("continuum:2:200");
  fo.forces_pN = {0, 30, 75, 120, 150};
  const ForwardModel model(fo);
  const ForwardRun run = model.run(truth);
  EXPECT_TRUE(run.converged);
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> noise(0.0, noise_um);
  const std::string path = (dir / "stretch.csv").string();
  std::ofstream out(path);
  out << "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n";
  for (size_t k = 0; k < fo.forces_pN.size(); ++k) {
    const double a = run.diameters.axial_um[k] + noise(gen);
    const double t = k == 0 ? a : run.diameters.transverse_um[k] + noise(gen);
    out << fo.forces_pN[k] << "," << a << "," << noise_um << "," << t << "," << noise_um << "\n";
  }
  return path;
}

/// The inference's release scene: small and cheap.
RecoveryModelOptions recovery_options() {
  RecoveryModelOptions o;
  o.elements = 200;
  return o;
}

/// Two cells' recovery (25 readings over 0.4 s each, their own lambda_0 and lambda_inf) from a
/// DIRECT release run at eta_m = kTruthEta (its reference viscosity; not through the time
/// rescaling the likelihood uses), Gaussian noise of sd 0.02 (seeded), in the data file format.
std::string recovery_file(const std::filesystem::path& dir, const ForwardParameters& truth,
                          unsigned seed) {
  RecoveryModelOptions direct = recovery_options();
  direct.eta_ref_pN_s_per_um = kTruthEta;
  direct.duration_s = 0.45 * kTruthEta / 0.7;
  const RecoveryCurve curve = simulate_recovery(truth, direct);
  EXPECT_TRUE(curve.converged) << curve.status;
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> noise(0.0, 0.02);
  const std::string path = (dir / "recovery.csv").string();
  std::ofstream out(path);
  out << "cell,time_s,length_over_width\n";
  const double cells[2][2] = {{2.05, 1.12}, {1.85, 1.05}};  // lambda_0, lambda_inf
  for (int c = 0; c < 2; ++c) {
    const double l0 = cells[c][0], linf = cells[c][1], r0 = (l0 - linf) / (l0 + linf);
    for (int i = 0; i < 25; ++i) {
      const double t = 0.001 * (c + 1) + 0.4 * i / 24.0;
      const double g = curve.at(t);  // the direct run's clock is the data's
      out << c + 1 << "," << t << "," << linf * (1 + r0 * g) / (1 - r0 * g) + noise(gen) << "\n";
    }
  }
  return path;
}

InferOptions joint_options(const std::string& stretch, const std::string& recovery) {
  InferOptions o;
  o.data_files = {stretch, recovery};
  o.method = parse_method("continuum:2:200");
  o.parameters = {Parameter::persistence, Parameter::lmax, Parameter::eta_m};
  o.priors = {
      {Parameter::persistence, 3, 16}, {Parameter::lmax, 150, 300}, {Parameter::eta_m, 0.3, 2.5}};
  o.recovery_model = recovery_options();
  return o;
}

struct Files {
  std::string stretch, recovery;
};
Files data_files(const std::string& name) {
  const auto dir = testing::fresh_output_dir(name);
  const ForwardParameters t = truth_parameters();
  return {stretch_table(dir, t, 0.1, 41), recovery_file(dir, t, 42)};
}

// d log L/d theta of the joint problem (stretch sensitivities + the recovery term) against
// central differences of the sampler's log L at relative steps 2e-2 and 1e-2 (the stretch runs
// solved to 1e-8 pN): eta_m's derivative (analytic in both terms) decays at order 2; p's and
// Lmax's recovery parts are themselves central differences of trajectories (step 1e-3), so the
// check there is agreement to the finer difference's error (0.5 % plus its h^2 term). The value
// and the gradient are the same bits at 1 and 2 OpenMP threads.
TEST(JointGradient, GradientWithRecoveryDataMatchesCentralDifferences) {
  const Files f = data_files("joint_gradient_fd");
  InferOptions o = joint_options(f.stretch, f.recovery);
  o.force_tolerance_pN = 1e-8;
  const InferenceProblem problem(o);
  const StretchSensitivity sens(problem.forward().options());
  const std::vector<double> theta = {10.0, 200.0, 0.8};
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const LikelihoodGradient g1 = log_likelihood_and_gradient(problem, sens, theta);
  omp_set_num_threads(2);
  const LikelihoodGradient g = log_likelihood_and_gradient(problem, sens, theta);
  omp_set_num_threads(saved);
  ASSERT_FALSE(g.failed);
  ASSERT_EQ(g.gradient.size(), 3u);
  EXPECT_EQ(g.recovery_trajectories, 5);  // centre + (p, Lmax) pairs; kappa not inferred
  EXPECT_EQ(g1.log_likelihood, g.log_likelihood);
  EXPECT_EQ(g1.gradient, g.gradient);
  EXPECT_TRUE(g1.information.isApprox(g.information, 0.0));
  const LikelihoodValue v = problem.likelihood().evaluate(theta, {}, nullptr);
  EXPECT_NEAR(g.log_likelihood, v.log_likelihood, 1e-6 * std::abs(v.log_likelihood));
  for (int k = 0; k < 3; ++k) {
    const auto fd = [&](double rel) {
      std::vector<double> a = theta, b = theta;
      const double h = rel * theta[k];
      a[k] += h;
      b[k] -= h;
      const double la = problem.likelihood().evaluate(a, g.state, nullptr).log_likelihood;
      const double lb = problem.likelihood().evaluate(b, g.state, nullptr).log_likelihood;
      return (la - lb) / (2 * h);
    };
    const double e1 = std::abs(fd(2e-2) - g.gradient[k]), e2 = std::abs(fd(1e-2) - g.gradient[k]);
    const double scale = std::abs(g.gradient[k]) * theta[k];  // log L over a unit relative step
    std::printf("d log L/d %s: %.6g, FD errors %.3g (2e-2), %.3g (1e-2)\n",
                problem.slots()[k].name.c_str(), g.gradient[k], e1, e2);
    EXPECT_GT(scale, 1.0) << k;  // not a flat direction
    if (k == 2) {
      EXPECT_LT(e2, 1e-3 * std::abs(g.gradient[k]) + 1e-6);
      if (e1 > 1e-5 * std::abs(g.gradient[k])) {
        const double order = std::log2(e1 / e2);
        EXPECT_GT(order, 1.5) << e1 << " " << e2;
        EXPECT_LT(order, 2.5) << e1 << " " << e2;
      }
    } else {
      EXPECT_LT(e2, 5e-3 * std::abs(g.gradient[k]) + e1 / 3) << e1;
      EXPECT_LT(e2, 2e-2 * std::abs(g.gradient[k])) << e1;
    }
  }
}

// The Gauss-Newton information of the joint problem: symmetric, positive semi-definite, and its
// eta_m entry (the recovery term alone; nuisances eliminated by the Schur complement) within
// 20 % of -d2 log L/d eta_m^2 from central differences of the analytic derivative near the
// truth, where the residuals are noise and Gauss-Newton is the observed information's
// expectation. A Gauss-Newton matrix that kept the nuisance block (no Schur complement) is
// larger, and one without the eta_m column is 0.
TEST(JointGradient, RecoveryInformationIsTheCurvatureInTheViscosity) {
  const Files f = data_files("joint_gradient_information");
  const InferenceProblem problem(joint_options(f.stretch, f.recovery));
  const StretchSensitivity sens(problem.forward().options());
  const std::vector<double> theta = {9.0, 190.0, kTruthEta};
  const LikelihoodGradient g = log_likelihood_and_gradient(problem, sens, theta);
  ASSERT_FALSE(g.failed);
  const Eigen::MatrixXd& F = g.information;
  EXPECT_TRUE(F.isApprox(F.transpose(), 1e-12));
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(F);
  EXPECT_GT(es.eigenvalues().minCoeff(), -1e-9 * es.eigenvalues().maxCoeff());
  const RecoveryModel& model = *problem.recovery_model();
  const RecoveryCurve curve = model.simulate(problem.physical(theta, 1));
  const RecoveryData data = read_recovery_data(f.recovery);
  const double h = 1e-3 * kTruthEta;
  const double d2 =
      (evaluate_recovery_likelihood(curve, kTruthEta + h, data).dlog_deta_per_pN_s_per_um -
       evaluate_recovery_likelihood(curve, kTruthEta - h, data).dlog_deta_per_pN_s_per_um) /
      (2 * h);
  std::printf("information eta-eta %.5g, -d2 log L/d eta2 %.5g\n", F(2, 2), -d2);
  EXPECT_NEAR(F(2, 2), -d2, 0.2 * std::abs(d2));
}

// Synthetic truth: a stretch table (5 forces, noise 0.1 um) and two cells' recovery (noise 0.02)
// generated inside the test at p = 9 nm, Lmax = 190 nm, eta_m = 0.93 pN s/um; the joint
// posterior over (p, eta_m), Lmax fixed, by laplace-is (200 importance samples, one thread) has
// eta_m and mu inside their 90 % intervals, and eta_m's interval narrower than +-25 % (the recovery
// data carry it). Seeds fixed, not selected: a calibrated posterior misses the truth with
// probability ~10 % per quantity over new noise draws.
TEST(JointGradient, JointStretchAndRecoveryPosteriorHoldsTheTruth) {
  const Files f = data_files("joint_gradient_truth");
  InferOptions o = joint_options(f.stretch, f.recovery);
  // Lmax fixed at its true value: with both free the (p, Lmax) ridge of five stretch points is
  // curved in logit coordinates and 300 importance draws gave an ESS of 8.5 (too few to trust
  // the intervals), in more CPU than this test's budget.
  o.parameters = {Parameter::persistence, Parameter::eta_m};
  o.priors = {{Parameter::persistence, 3, 16}, {Parameter::eta_m, 0.3, 2.5}};
  o.fixed.lmax_nm = truth_parameters().lmax_nm;
  o.sampler_kind = SamplerKind::laplace_is;
  o.is_samples = 200;
  o.sampler.seed = 5;
  o.threads = 1;
  const InferenceResult r = run_inference(o);
  ASSERT_EQ(r.status, TmcmcStatus::converged);
  const ForwardParameters t = truth_parameters();
  const double truth_mu = sample_moduli(t).mu_pN_per_um * units::uN_per_m_per_pN_per_um;
  const Summary& eta = r.parameters[1];
  std::printf(
      "p %.3g [%.3g, %.3g], eta_m %.4g [%.4g, %.4g] (truth %.2f), mu %.4g [%.4g, %.4g] (truth "
      "%.4g), ESS %.1f, log evidence %.3f\n",
      r.parameters[0].q50, r.parameters[0].q05, r.parameters[0].q95, eta.q50, eta.q05, eta.q95,
      kTruthEta, r.mu.q50, r.mu.q05, r.mu.q95, truth_mu, r.ess, r.log_evidence);
  EXPECT_LE(eta.q05, kTruthEta);
  EXPECT_GE(eta.q95, kTruthEta);
  EXPECT_LT(eta.q95 - eta.q05, 0.5 * kTruthEta);
  EXPECT_LE(r.mu.q05, truth_mu);
  EXPECT_GE(r.mu.q95, truth_mu);
  EXPECT_TRUE(std::isfinite(r.log_evidence));
  EXPECT_GT(r.ess, 20.0);
}

}  // namespace
}  // namespace joint_gradient_test
}  // namespace rbc
