// SPDX-License-Identifier: GPL-3.0-or-later
// Several experiments in one likelihood (calibrate/infer.hpp, calibrate/likelihood.hpp): the
// joint log-likelihood is the sum of the single-file ones, computed by the single-file path;
// shared forces are solved once; the hierarchical layer's closed form equals a dense
// multivariate normal density (Eigen LLT) and tends to the independent likelihood as tau -> 0;
// its gradient and information against central differences and dense algebra.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "calibrate/infer.hpp"
#include "calibrate/likelihood.hpp"
#include "test_output.hpp"

namespace rbc {
namespace joint_likelihood_test {  // named: the unity build merges anonymous ones

/// log N(r; 0, diag(s^2) + tau^2 1 1') by a dense Cholesky factorisation: the independent truth.
double dense_log_density(const std::vector<double>& r, const std::vector<double>& s, double tau) {
  const int n = static_cast<int>(r.size());
  Eigen::MatrixXd cov = Eigen::MatrixXd::Constant(n, n, tau * tau);
  for (int i = 0; i < n; ++i) cov(i, i) += s[i] * s[i];
  const Eigen::LLT<Eigen::MatrixXd> llt(cov);
  EXPECT_EQ(llt.info(), Eigen::Success);
  const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(r.data(), n);
  const Eigen::VectorXd z = llt.matrixL().solve(x);
  const double log_det = 2 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  return -0.5 * (z.squaredNorm() + log_det + n * std::log(2 * M_PI));
}

struct Block {
  std::vector<double> r, s;
};
Block random_block(int n, unsigned seed) {
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> z(0.0, 0.7);
  std::uniform_real_distribution<double> u(0.3, 2.0);
  Block b;
  for (int i = 0; i < n; ++i) {
    b.r.push_back(z(gen) + 0.4);  // a common shift, as the offset model describes
    b.s.push_back(u(gen));
  }
  return b;
}

TEST(JointLikelihood, HierarchicalDensityEqualsTheDenseMultivariateNormal) {
  for (unsigned seed : {1u, 2u, 3u})
    for (int n : {1, 5, 13})
      for (double tau : {0.0, 0.05, 0.4, 2.5}) {
        const Block b = random_block(n, seed);
        const double closed = shared_offset_log_density(b.r, b.s, tau);
        const double dense = dense_log_density(b.r, b.s, tau);
        EXPECT_NEAR(closed, dense, 1e-10 * std::max(1.0, std::abs(dense)))
            << "n " << n << " tau " << tau;
      }
}

DiameterData small_data() {
  std::vector<ExperimentPoint> pts;
  const double f[] = {0, 20, 50, 100};
  for (int k = 0; k < 4; ++k) {
    ExperimentPoint p;
    p.force_pN = f[k];
    p.axial_um = 7.8 + 0.05 * f[k];
    p.axial_err_um = 0.3 + 0.01 * k;
    p.transverse_um = k == 0 ? p.axial_um : 7.8 - 0.02 * f[k];
    p.transverse_err_um = 0.4 - 0.02 * k;
    pts.push_back(p);
  }
  return make_diameter_data(pts, 0.0);
}

TEST(JointLikelihood, ExperimentLikelihoodIsTwoDenseColumnsAndTendsToTheIndependentOne) {
  const DiameterData d = small_data();
  ModelDiameters m;
  for (int k = 0; k < d.size(); ++k) {
    m.axial_um.push_back(d.axial_um[k] + 0.3 + 0.1 * k);
    m.transverse_um.push_back(d.transverse_um[k] - 0.2);
  }
  const double c = 1.3;
  for (double tau : {0.1, 0.8}) {
    std::vector<double> ra, sa, rt, st;
    for (int k = 0; k < d.size(); ++k) {
      ra.push_back(m.axial_um[k] - d.axial_um[k]);
      sa.push_back(c * d.axial_sigma_um[k]);
      if (k > 0) {  // the 0 pN point enters once, as an axial term
        rt.push_back(m.transverse_um[k] - d.transverse_um[k]);
        st.push_back(c * d.transverse_sigma_um[k]);
      }
    }
    EXPECT_NEAR(gaussian_log_likelihood(d, m, c, tau),
                dense_log_density(ra, sa, tau) + dense_log_density(rt, st, tau), 1e-10);
  }
  const double independent = gaussian_log_likelihood(d, m, c);
  EXPECT_EQ(gaussian_log_likelihood(d, m, c, 0.0), independent);
  double previous = INFINITY;
  for (double tau : {1e-1, 1e-2, 1e-3, 1e-4, 1e-6}) {
    const double gap = std::abs(gaussian_log_likelihood(d, m, c, tau) - independent);
    EXPECT_LT(gap, previous);
    previous = gap;
  }
  EXPECT_LT(previous, 1e-9);
}

TEST(JointLikelihood, BlockGradientAndInformationMatchFiniteDifferencesAndDenseAlgebra) {
  // A linear residual model r(x) = r0 + J x in two slots, with the scale c and tau.
  const Block b = random_block(6, 7);
  const int n = 6, slots = 2;
  std::vector<double> jac(n * slots);
  for (int i = 0; i < n; ++i) {
    jac[i] = 0.3 + 0.1 * i;            // slot 0
    jac[n + i] = -0.2 + 0.05 * i * i;  // slot 1
  }
  const double c = 1.4, tau = 0.35;
  const auto f = [&](double x0, double x1, double cc, double tt) {
    std::vector<double> r(n), s(n);
    for (int i = 0; i < n; ++i) {
      r[i] = b.r[i] + jac[i] * x0 + jac[n + i] * x1;
      s[i] = cc * b.s[i];
    }
    return dense_log_density(r, s, tt);
  };
  const GaussianBlockGradient g = gaussian_block_gradient(b.r, b.s, jac, slots, c, tau);
  EXPECT_NEAR(g.log_density, f(0, 0, c, tau), 1e-10);
  const double h = 1e-5;
  EXPECT_NEAR(g.gradient[0], (f(h, 0, c, tau) - f(-h, 0, c, tau)) / (2 * h), 1e-6);
  EXPECT_NEAR(g.gradient[1], (f(0, h, c, tau) - f(0, -h, c, tau)) / (2 * h), 1e-6);
  EXPECT_NEAR(g.d_scale, (f(0, 0, c + h, tau) - f(0, 0, c - h, tau)) / (2 * h), 1e-6);
  EXPECT_NEAR(g.d_tau, (f(0, 0, c, tau + h) - f(0, 0, c, tau - h)) / (2 * h), 1e-6);
  // J' Sigma^-1 J densely.
  Eigen::MatrixXd cov = Eigen::MatrixXd::Constant(n, n, tau * tau);
  for (int i = 0; i < n; ++i) cov(i, i) += c * c * b.s[i] * b.s[i];
  const Eigen::Map<const Eigen::MatrixXd> J(jac.data(), n, slots);
  const Eigen::MatrixXd info = J.transpose() * cov.llt().solve(J);
  for (int k = 0; k < slots * slots; ++k) EXPECT_NEAR(g.information[k], info.data()[k], 1e-10);
  // The variance parameters' Fisher information: tau = 0 gives 2 n / c^2 for the scale.
  const GaussianBlockGradient g0 = gaussian_block_gradient(b.r, b.s, jac, slots, c, 0.0);
  EXPECT_NEAR(g0.info_scale, 2.0 * n / (c * c), 1e-10);
  EXPECT_EQ(g0.info_tau, 0.0);
}

/// A stretch-data file of `points` (force, axial, transverse) with error bars `err_um`.
std::string write_table(const std::filesystem::path& dir, const std::string& stem,
                        const std::vector<std::array<double, 3>>& points, double err_um) {
  const std::string path = (dir / (stem + ".csv")).string();
  std::ofstream out(path);
  out << "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n";
  for (const auto& p : points)
    out << p[0] << "," << p[1] << "," << err_um << "," << p[2] << "," << err_um << "\n";
  return path;
}

InferOptions small_options() {
  InferOptions o;
  o.method = parse_method("continuum:2:200");
  o.parameters = {Parameter::persistence, Parameter::lmax, Parameter::sigma_scale};
  // Tight Newton tolerance: the union-of-forces run and the single-file runs continue in force
  // through different steps; at 1e-7 pN their equilibria agree to ~1e-7 um.
  o.force_tolerance_pN = 1e-7;
  return o;
}

struct Files {
  std::string a, b;
};
Files two_tables(const std::string& name) {
  const auto dir = testing::fresh_output_dir(name);
  // Forces 0 and 100 pN in both: the joint run solves them once.
  return {write_table(dir, "table_a",
                      {{{0, 7.9, 7.9}, {20, 9.4, 6.6}, {50, 11.3, 5.6}, {100, 13.6, 4.7}}}, 0.3),
          write_table(dir, "table_b",
                      {{{0, 7.7, 7.7}, {35, 10.2, 6.0}, {100, 13.9, 4.5}, {150, 15.2, 4.3}}}, 0.5)};
}

double evaluate(const InferenceProblem& p, const std::vector<double>& theta) {
  const LikelihoodValue v = p.likelihood().evaluate(theta, {}, nullptr);
  EXPECT_FALSE(v.failed);
  return v.log_likelihood;
}

TEST(JointLikelihood, IsTheSumOfTheSingleFileLikelihoodsWithSharedForcesSolvedOnce) {
  const Files f = two_tables("joint_likelihood_sum");
  InferOptions joint = small_options(), a = small_options(), b = small_options();
  joint.data_files = {f.a, f.b};
  joint.extra_uncertainty_by_file = {{"table_b", 0.2}};
  a.data_file = f.a;
  b.data_file = f.b;
  b.extra_uncertainty_um = 0.2;
  const InferenceProblem pj(joint), pa(a), pb(b);
  // One forward run over the union of the forces: 0 and 100 pN once (6 forces, not 8).
  ASSERT_EQ(pj.groups(), 1);
  EXPECT_EQ(pj.forward().options().forces_pN, (std::vector<double>{0, 20, 35, 50, 100, 150}));
  ASSERT_EQ(pj.experiments().size(), 2u);
  EXPECT_EQ(pj.experiments()[1].data.axial_sigma_um[0], pb.data().axial_sigma_um[0]);
  for (const std::vector<double>& theta :
       {std::vector<double>{9.0, 200.0, 1.0}, std::vector<double>{14.0, 260.0, 0.7}}) {
    const double lj = evaluate(pj, theta), la = evaluate(pa, theta), lb = evaluate(pb, theta);
    EXPECT_NEAR(lj, la + lb, 1e-5 * std::abs(la + lb)) << lj << " vs " << la << " + " << lb;
    EXPECT_GT(std::abs(lj - la), 1.0);  // both terms matter at these points
    EXPECT_GT(std::abs(lj - lb), 1.0);
  }
}

TEST(JointLikelihood, PerExperimentContactFractionMovesOnlyItsOwnExperiment) {
  const Files f = two_tables("joint_likelihood_per_experiment");
  InferOptions joint = small_options(), a = small_options(), b = small_options();
  joint.parameters = {Parameter::persistence, Parameter::lmax, Parameter::contact_fraction};
  joint.per_experiment = {Parameter::contact_fraction};
  joint.data_files = {f.a, f.b};
  a.parameters =
      b.parameters = {Parameter::persistence, Parameter::lmax, Parameter::contact_fraction};
  a.data_file = f.a;
  b.data_file = f.b;
  const InferenceProblem pj(joint), pa(a), pb(b);
  ASSERT_EQ(pj.slots().size(), 4u);
  EXPECT_EQ(pj.names()[2], "contact-fraction[table_a]");
  EXPECT_EQ(pj.names()[3], "contact-fraction[table_b]");
  EXPECT_EQ(pj.groups(), 2);  // each experiment its own forward parameters
  const double lj = evaluate(pj, {10.0, 220.0, 0.03, 0.09});
  const double la = evaluate(pa, {10.0, 220.0, 0.03}), lb = evaluate(pb, {10.0, 220.0, 0.09});
  EXPECT_NEAR(lj, la + lb, 1e-9 * std::abs(la + lb));
  // Another value for b's fraction leaves a's term.
  const double lj2 = evaluate(pj, {10.0, 220.0, 0.03, 0.05});
  EXPECT_NEAR(lj2, la + evaluate(pb, {10.0, 220.0, 0.05}), 1e-9 * std::abs(lj2));
}

TEST(JointLikelihood, BadOptionsAreRefusedNamingTheValue) {
  const Files f = two_tables("joint_likelihood_bad");
  InferOptions o = small_options();
  o.data_files = {f.a, f.b};
  o.extra_uncertainty_by_file = {{"table_c", 0.1}};
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.extra_uncertainty_by_file = {{"table_a", -1}};
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.extra_uncertainty_by_file = {};
  o.per_experiment = {Parameter::contact_fraction};  // not inferred
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.per_experiment = {Parameter::sigma_scale};  // not a forward parameter
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.per_experiment = {};
  o.data_files = {f.a, f.a};  // the same stem twice
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o.data_files = {f.a, f.b};
  o.parameters = {Parameter::persistence, Parameter::eta_m};  // no recovery data
  EXPECT_THROW(InferenceProblem{o}, std::invalid_argument);
}

TEST(JointLikelihood, RecoveryDataAddTheirReleaseSceneLikelihoodToTheStretchOnes) {
  const Files f = two_tables("joint_likelihood_recovery");
  const std::string cells = default_data_directory() + "/hochmuth1979_recovery_cells.csv";
  InferOptions joint = small_options(), stretch = small_options();
  joint.parameters =
      stretch.parameters = {Parameter::persistence, Parameter::lmax, Parameter::eta_m};
  joint.data_files = {f.a, cells};
  joint.recovery_model.elements = 200;  // small and cheap: the identity, not the physics
  stretch.data_file = f.a;
  stretch.parameters = {Parameter::persistence, Parameter::lmax};
  const InferenceProblem pj(joint), ps(stretch);
  ASSERT_EQ(pj.experiments().size(), 2u);
  EXPECT_EQ(pj.experiments()[1].kind, DataKind::recovery);
  EXPECT_EQ(pj.groups(), 1);  // the recovery file runs the release scene, not the stretch
  const std::vector<double> theta = {9.0, 200.0, 0.8};
  ForwardParameters p;
  p.persistence_nm = 9.0;
  p.lmax_nm = 200.0;
  const RecoveryCurve curve = simulate_recovery(p, joint.recovery_model);
  ASSERT_TRUE(curve.converged) << curve.status;
  const double lr = recovery_log_likelihood(curve, 0.8, read_recovery_data(cells));
  const double ls = evaluate(ps, {9.0, 200.0});
  EXPECT_NEAR(evaluate(pj, theta), ls + lr, 1e-9 * std::abs(ls + lr));
  // Without eta-m, or with the gradient sampler and contact-fraction inferred (the recovery
  // term's gradient does not cover it), recovery data are refused before any work.
  InferOptions bad = joint;
  bad.parameters = {Parameter::persistence, Parameter::lmax};
  EXPECT_THROW(InferenceProblem{bad}, std::invalid_argument);
  bad = joint;
  bad.sampler_kind = SamplerKind::laplace_is;
  bad.parameters.push_back(Parameter::contact_fraction);
  EXPECT_THROW(InferenceProblem{bad}, std::invalid_argument);
  bad = joint;
  bad.data_files = {cells, f.a};  // stretch data first
  EXPECT_THROW(InferenceProblem{bad}, std::invalid_argument);
}

}  // namespace joint_likelihood_test
}  // namespace rbc
