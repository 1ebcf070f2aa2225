// SPDX-License-Identifier: GPL-3.0-or-later
// The recovery likelihood (calibrate/recovery_likelihood.hpp): the data reader, the time
// rescaling of the continuum release scene against a direct run, the analytic eta_m derivative,
// and the recovery of a synthetic truth.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "calibrate/recovery_likelihood.hpp"
#include "compare/experiment.hpp"
#include "discrete/dynamics.hpp"
#include "invalid_parameter.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

std::string write_file(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// Both bundled files: the four cells (25 points each) and the single-cell file, which is cell 1
// of the other to its fewer digits.
TEST(RecoveryData, ReadsTheFourCellsAndTheSingleCellFile) {
  const RecoveryData four =
      read_recovery_data(default_data_directory() + "/hochmuth1979_recovery_cells.csv");
  ASSERT_EQ(four.cells.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(four.cells[k].id, k + 1);
    EXPECT_EQ(four.cells[k].time_s.size(), 25u);
  }
  EXPECT_EQ(four.points(), 100);
  EXPECT_DOUBLE_EQ(four.cells[0].time_s[0], 0.00055);
  EXPECT_DOUBLE_EQ(four.cells[0].length_over_width[0], 2.0045);
  EXPECT_DOUBLE_EQ(four.sigma_ratio, 0.02);
  EXPECT_EQ(four.content_hash.size(), 16u);
  const RecoveryData one =
      read_recovery_data(default_data_directory() + "/hochmuth1979_recovery.csv");
  ASSERT_EQ(one.cells.size(), 1u);
  EXPECT_EQ(one.cells[0].id, 1);
  ASSERT_GE(one.cells[0].time_s.size(), 3u);
  for (size_t i = 0; i < std::min<size_t>(one.cells[0].time_s.size(), 25); ++i) {
    EXPECT_NEAR(one.cells[0].time_s[i], four.cells[0].time_s[i], 1e-3);
    EXPECT_NEAR(one.cells[0].length_over_width[i], four.cells[0].length_over_width[i], 1e-3);
  }
  EXPECT_NE(one.content_hash, four.content_hash);
}

// A corrupt file is refused with rbc::InvalidParameter naming the file and the line.
TEST(RecoveryData, CorruptFilesAreRefusedNamingTheLine) {
  const std::string dir = testing::fresh_output_dir("recovery_data_corrupt").string();
  const std::string head = "# comment\ncell,time_s,length_over_width\n1,0.0,2.0\n1,0.1,1.5\n";
  struct Case {
    std::string name, body, expect;
  };
  const std::vector<Case> cases = {
      {"text.csv", head + "1,0.2,abc\n", "line 5 must be a finite number, got 'abc'"},
      {"short.csv", head + "1,0.2\n", "line 5 must be 3 comma-separated numbers"},
      {"time.csv", head + "1,0.05,1.4\n", "line 5 time_s must be greater than"},
      {"ratio.csv", head + "1,0.2,-1\n", "line 5 length_over_width must be > 0"},
      {"cell.csv", head + "1.5,0.2,1.4\n", "line 5 cell must be a positive integer"},
      {"split.csv", head + "1,0.2,1.4\n2,0,2\n2,0.1,1.9\n2,0.2,1.8\n1,0.3,1.3\n",
       "line 9 cell must be the rows of each cell together"},
      {"header.csv", "# c\ntime,ratio\n0,2\n", "line 2 must be the header"},
      {"few.csv", "time_s,length_over_width\n0,2\n0.1,1.5\n", "cell 1 must be at least 3 points"},
      {"nan.csv", head + "1,nan,1.4\n", "line 5 must be a finite number, got 'nan'"},
  };
  for (const Case& c : cases) {
    const std::string path = write_file(dir, c.name, c.body);
    const std::string msg = testing::limit_refusal([&] { read_recovery_data(path); });
    EXPECT_NE(msg.find("recovery data file '" + path + "'"), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.expect), std::string::npos) << c.name << ": " << msg;
  }
  const std::string missing = dir + "/missing.csv";
  EXPECT_NE(testing::limit_refusal([&] { read_recovery_data(missing); }).find("readable"),
            std::string::npos);
}

/// The release scene at the test's size: 400 elements (0.3 s CPU per curve with the
/// extrapolation; the default 1,000 elements shift the Hochmuth MLE by 1.5 %).
RecoveryModelOptions small_options() {
  RecoveryModelOptions o;
  o.elements = 400;
  return o;
}

// The interpolation of log g is exact for an exponential (inside and beyond the samples), and
// its derivative is dg/dt.
TEST(RecoveryCurve, InterpolatesAnExponentialExactly) {
  RecoveryCurve c;
  c.converged = true;
  const double tau = 0.083;
  for (int k = 0; k <= 30; ++k) {
    c.time_s.push_back(0.01 * k + (k > 10 ? 0.004 : 0.0));  // a non-uniform grid
    c.shape.push_back(std::exp(-c.time_s.back() / tau));
  }
  for (double t : {0.0, 0.0037, 0.05, 0.1061, 0.2999, 0.31, 0.5}) {
    double gp = 0;
    const double g = c.at(t, &gp);
    EXPECT_NEAR(g, std::exp(-t / tau), 1e-12 * std::exp(-t / tau) + 1e-15) << t;
    EXPECT_NEAR(gp, -std::exp(-t / tau) / tau, 1e-9 / tau) << t;
  }
}

// Time rescaling (calibrate/recovery_likelihood.hpp): the continuum release step problem at
// (eta_m, dt) is the one at (eta_ref, dt eta_ref/eta_m), so
//  (a) a run at 2 eta_ref and 2 dt (the step force tolerance per unit time halved, so the
//      tolerance in pN is the same) reproduces the eta_ref curve on the doubled clock to the
//      solver's tolerance (bound 1e-6 in g; measured: identical to the last bit);
//  (b) a direct run at 2 eta_ref with the same dt differs from the rescaled eta_ref curve by the
//      time-stepping error: at the eta_ref curve's samples below 3e-4 in g with the Richardson
//      extrapolation (measured 9.6e-5), 10 x more for plain backward Euler (measured 2.8e-3);
//      between samples the interpolation of log g adds below 5e-4 (measured 2.6e-4), and
//      2e-3 in the first interval, across the release's fast start (measured 1.2e-3);
//  (c) the fitted t_c doubles (to 0.5 % with the extrapolation, 5 % without).
// The discrete scene's exact doubling is CliDynamics.RecoveryTimeIsProportionalToTheMembrane-
// Viscosity (tests/app/test_cli_dynamics.cpp).
TEST(RecoveryCurve, ADirectRunAtTwiceTheViscosityIsTheRescaledCurve) {
  const ForwardParameters p;
  const RecoveryModelOptions o = small_options();
  const RecoveryCurve ref = simulate_recovery(p, o);
  ASSERT_TRUE(ref.converged) << ref.status;
  RecoveryModelOptions o2 = o;
  o2.eta_ref_pN_s_per_um = 2 * o.eta_ref_pN_s_per_um;
  o2.dt_s = 2 * o.dt_s;
  o2.duration_s = 2 * o.duration_s;
  o2.step_tolerance_pN_per_s = 0.5 * o.step_tolerance_pN_per_s;
  const RecoveryCurve same_steps = simulate_recovery(p, o2);
  ASSERT_TRUE(same_steps.converged) << same_steps.status;
  ASSERT_EQ(same_steps.time_s.size(), ref.time_s.size());
  double worst_same = 0;
  for (size_t k = 0; k < ref.time_s.size(); ++k) {
    ASSERT_NEAR(same_steps.time_s[k], 2 * ref.time_s[k], 1e-12);
    worst_same = std::max(worst_same, std::abs(same_steps.shape[k] - ref.shape[k]));
  }
  EXPECT_LT(worst_same, 1e-6);

  o2.dt_s = o.dt_s;
  o2.step_tolerance_pN_per_s = o.step_tolerance_pN_per_s;
  struct Gap {
    double at_samples = 0, between = 0, first_interval = 0;
  };
  const auto direct_gap = [&](bool richardson) {
    RecoveryModelOptions a = o, b = o2;
    a.richardson = b.richardson = richardson;
    const RecoveryCurve r = simulate_recovery(p, a);
    const RecoveryCurve d = simulate_recovery(p, b);
    EXPECT_TRUE(r.converged && d.converged);
    Gap gap;
    for (size_t k = 0; k < d.time_s.size(); ++k) {
      const double diff = std::abs(d.shape[k] - r.at(d.time_s[k] / 2));
      if (k % 2 == 0) {  // t/2 is a sample of the eta_ref curve
        EXPECT_NEAR(r.time_s[k / 2], d.time_s[k] / 2, 1e-12);
        gap.at_samples = std::max(gap.at_samples, diff);
      } else {
        (k == 1 ? gap.first_interval : gap.between) =
            std::max(k == 1 ? gap.first_interval : gap.between, diff);
      }
    }
    const double eta2 = o2.eta_ref_pN_s_per_um;
    EXPECT_NEAR(d.recovery_time_s(eta2) / r.recovery_time_s(eta2), 1.0, richardson ? 5e-3 : 5e-2);
    std::printf(
        "extrapolation %d: |g_direct - g_rescaled| <= %.2e at the samples, %.2e between, "
        "%.2e in the first interval; (eta_m, dt) -> (2 eta_m, 2 dt): %.2e\n",
        richardson, gap.at_samples, gap.between, gap.first_interval, worst_same);
    return gap;
  };
  const Gap with = direct_gap(true), without = direct_gap(false);
  EXPECT_LT(with.at_samples, 3e-4);
  EXPECT_GT(without.at_samples, 10 * with.at_samples);  // the difference is the stepping error
  EXPECT_LT(with.between, 5e-4);
  EXPECT_LT(with.first_interval, 2e-3);
}

/// Hochmuth-like cells from `curve` at eta_m: 25 readings each over 0.4 s, lambda_0 and
/// lambda_inf per cell, Gaussian noise of sd `sigma` (seeded).
RecoveryData synthetic_cells(const RecoveryCurve& curve, double eta_m, double sigma,
                             unsigned seed) {
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  RecoveryData d;
  d.sigma_ratio = sigma;
  const double cells[3][2] = {{2.05, 1.12}, {1.85, 1.05}, {2.2, 1.2}};  // lambda_0, lambda_inf
  for (int c = 0; c < 3; ++c) {
    RecoveryCell cell;
    cell.id = c + 1;
    const double l0 = cells[c][0], linf = cells[c][1];
    const double r0 = (l0 - linf) / (l0 + linf);
    for (int i = 0; i < 25; ++i) {
      const double t = 0.001 * (c + 1) + 0.4 * i / 24.0;
      const double g = curve.at(t * curve.eta_ref_pN_s_per_um / eta_m);
      cell.time_s.push_back(t);
      cell.length_over_width.push_back(linf * (1 + r0 * g) / (1 - r0 * g) + noise(gen));
    }
    d.cells.push_back(cell);
  }
  return d;
}

// The maximum of the likelihood in eta_m from a 1-d scan refined by the zero of the analytic
// derivative; and the 90 % likelihood-ratio interval (log L within chi2_1(0.9)/2 = 1.3528 of
// the maximum).
struct EtaProfile {
  double mle = 0, lo = 0, hi = 0;
};
EtaProfile eta_profile(const RecoveryCurve& curve, const RecoveryData& data,
                       const RecoveryLikelihoodOptions& lo) {
  const auto ll = [&](double eta) { return recovery_log_likelihood(curve, eta, data, lo); };
  double best = -1e300, eta_best = 0;
  const double step = 0.01;
  for (double eta = 0.3; eta <= 2.5; eta += step)
    if (ll(eta) > best) best = ll(eta), eta_best = eta;
  double a = eta_best - step, b = eta_best + step;
  for (int it = 0; it < 50; ++it) {  // bisection on d log L/d eta
    const double m = 0.5 * (a + b);
    (evaluate_recovery_likelihood(curve, m, data, lo).dlog_deta_per_pN_s_per_um > 0 ? a : b) = m;
  }
  EtaProfile p;
  p.mle = 0.5 * (a + b);
  const double top = ll(p.mle), cut = top - 1.3528;
  EXPECT_GE(top, best - 1e-9);
  const auto edge = [&](double inside, double outside) {
    for (int it = 0; it < 50; ++it) {
      const double m = 0.5 * (inside + outside);
      (ll(m) > cut ? inside : outside) = m;
    }
    return 0.5 * (inside + outside);
  };
  p.lo = edge(p.mle, 0.3);
  p.hi = edge(p.mle, 2.5);
  return p;
}

// Synthetic truth: three cells generated inside the test from a DIRECT run at eta_true (not
// through the rescaling) with per-cell lambda_0, lambda_inf and Gaussian noise of sd 0.02
// (seeded; not selected to pass). The likelihood built from the eta_ref = 0.7 curve, by the
// rescaling, has its maximum within its 90 % interval of eta_true, for both nuisance
// treatments; the interval is narrower than +-10 % (the test has power), and the fitted
// nuisances are within 0.05 of theirs.
TEST(RecoveryLikelihoodTest, RecoversASyntheticViscosityWithinItsNinetyPercentInterval) {
  const ForwardParameters p;
  const double eta_true = 0.93;
  RecoveryModelOptions direct = small_options();
  direct.eta_ref_pN_s_per_um = eta_true;
  direct.duration_s = 0.45 * eta_true / 0.7;
  const RecoveryCurve truth_curve = simulate_recovery(p, direct);
  ASSERT_TRUE(truth_curve.converged) << truth_curve.status;
  const RecoveryData data = synthetic_cells(truth_curve, eta_true, 0.02, 20261206);
  const RecoveryCurve curve = simulate_recovery(p, small_options());
  ASSERT_TRUE(curve.converged) << curve.status;
  for (RecoveryNuisances nu : {RecoveryNuisances::laplace, RecoveryNuisances::profile}) {
    RecoveryLikelihoodOptions lo;
    lo.nuisances = nu;
    const EtaProfile e = eta_profile(curve, data, lo);
    std::printf("eta_m MLE %.4f, 90 %% interval [%.4f, %.4f], truth %.2f\n", e.mle, e.lo, e.hi,
                eta_true);
    EXPECT_LT(e.lo, eta_true);
    EXPECT_GT(e.hi, eta_true);
    EXPECT_LT(e.hi - e.lo, 0.2 * eta_true);
    const RecoveryLikelihood r = evaluate_recovery_likelihood(curve, e.mle, data, lo);
    ASSERT_EQ(r.cells.size(), 3u);
    const double expect[3][2] = {{2.05, 1.12}, {1.85, 1.05}, {2.2, 1.2}};
    for (int c = 0; c < 3; ++c) {
      EXPECT_TRUE(r.cells[c].converged);
      EXPECT_NEAR(r.cells[c].lambda_0, expect[c][0], 0.05);
      EXPECT_NEAR(r.cells[c].lambda_inf, expect[c][1], 0.05);
    }
  }
}

// d log L/d eta_m, analytic through the rescaling (the nuisance modes' motion included in the
// Laplace determinant), against central differences of log L on the same curve: relative
// agreement 1e-5 for both treatments at three viscosities, and the difference falls with the
// step (second order away from the interpolation's knots).
TEST(RecoveryLikelihoodTest, ViscosityDerivativeMatchesCentralDifferences) {
  const RecoveryCurve curve = simulate_recovery(ForwardParameters{}, small_options());
  ASSERT_TRUE(curve.converged) << curve.status;
  const RecoveryData data = synthetic_cells(curve, 0.8, 0.02, 7);
  for (RecoveryNuisances nu : {RecoveryNuisances::laplace, RecoveryNuisances::profile}) {
    RecoveryLikelihoodOptions lo;
    lo.nuisances = nu;
    for (double eta : {0.55, 0.81, 1.3}) {
      const double d = evaluate_recovery_likelihood(curve, eta, data, lo).dlog_deta_per_pN_s_per_um;
      const auto cd = [&](double h) {
        return (recovery_log_likelihood(curve, eta + h, data, lo) -
                recovery_log_likelihood(curve, eta - h, data, lo)) /
               (2 * h);
      };
      const double c1 = cd(1e-4 * eta), c2 = cd(0.5e-4 * eta);
      EXPECT_NEAR(d, c2, 1e-5 * std::abs(d) + 1e-4) << eta;
      EXPECT_LE(std::abs(d - c2), std::abs(d - c1) + 1e-6) << eta;
    }
  }
}

// The p, Lmax and kappa derivatives by central differences of whole trajectories: the step
// size does not matter to 5 % (h = 1e-3 against 4e-3 relative; the trajectories' solver noise
// is below the signal), and the eta_m derivative is the analytic one.
TEST(RecoveryLikelihoodTest, ParameterDerivativesAreStableInTheStep) {
  const RecoveryModel model(small_options());
  const ForwardParameters p;
  const RecoveryData data = synthetic_cells(model.simulate(p), 0.8, 0.02, 3);
  const RecoveryGradient a = recovery_log_likelihood_gradient(model, p, 0.8, data, {}, 1e-3);
  const RecoveryGradient b = recovery_log_likelihood_gradient(model, p, 0.8, data, {}, 4e-3);
  ASSERT_TRUE(a.converged && b.converged);
  std::printf(
      "dlogL: d/dp %.4g vs %.4g per nm, d/dLmax %.4g vs %.4g per nm, d/dkappa %.4g vs "
      "%.4g per J, d/deta %.4g\n",
      a.d_persistence_per_nm, b.d_persistence_per_nm, a.d_lmax_per_nm, b.d_lmax_per_nm,
      a.d_kappa_per_J, b.d_kappa_per_J, a.d_eta_per_pN_s_per_um);
  EXPECT_NEAR(a.d_persistence_per_nm, b.d_persistence_per_nm,
              0.05 * std::abs(b.d_persistence_per_nm));
  EXPECT_NEAR(a.d_lmax_per_nm, b.d_lmax_per_nm, 0.05 * std::abs(b.d_lmax_per_nm));
  EXPECT_NEAR(a.d_kappa_per_J, b.d_kappa_per_J, 0.05 * std::abs(b.d_kappa_per_J));
  EXPECT_EQ(a.d_eta_per_pN_s_per_um, b.d_eta_per_pN_s_per_um);
}

TEST(RecoveryLikelihoodTest, OptionsAreValidated) {
  RecoveryModelOptions o;
  o.dt_s = 1.0;
  EXPECT_NE(testing::limit_refusal([&] { o.validate(); }).find("time step dt"), std::string::npos);
  o = {};
  o.release_force_pN = 500;
  EXPECT_NE(testing::limit_refusal([&] { o.validate(); }).find("release force"), std::string::npos);
  o = {};
  o.elements = 10;
  EXPECT_NE(testing::limit_refusal([&] { RecoveryModel m(o); }).find("elements"),
            std::string::npos);
  RecoveryLikelihoodOptions lo;
  lo.lambda_max = 0.5;
  EXPECT_NE(testing::limit_refusal([&] { lo.validate(); }).find("lambda_max"), std::string::npos);
  RecoveryCurve c;
  c.converged = true;
  c.time_s = {0, 0.01, 0.02};
  c.shape = {1, 0.9, 0.8};
  EXPECT_NE(testing::limit_refusal([&] {
              recovery_log_likelihood(c, -1.0, RecoveryData{});
            }).find("membrane viscosity"),
            std::string::npos);
}

// Measurement for docs/validation/recovery_likelihood.md (not run by default):
// OMP_NUM_THREADS=1 test_calibrate_recovery_likelihood --gtest_also_run_disabled_tests
//   --gtest_filter=RecoveryMeasure.*
TEST(RecoveryMeasure, DISABLED_HochmuthCellsAtThePaperParameters) {
  const RecoveryData data =
      read_recovery_data(default_data_directory() + "/hochmuth1979_recovery_cells.csv");
  for (const RecoveryCell& c : data.cells) {
    const RecoveryFit f = fit_recovery_free_limit(c.time_s, c.length_over_width);
    double ss = 0;
    for (size_t i = 0; i < c.time_s.size(); ++i) {
      const double m = f.m0 * std::exp(-c.time_s[i] / f.recovery_time_s);
      const double model = f.lambda_inf * (1 + m) / (1 - m);
      ss += (model - c.length_over_width[i]) * (model - c.length_over_width[i]);
    }
    std::printf(
        "cell %d single exponential: t_c %.4f +- %.4f s lambda_inf %.4f rms %.4f chi2/0.02^2 %.1f "
        "(n %zu)\n",
        c.id, f.recovery_time_s, f.recovery_time_err_s, f.lambda_inf,
        std::sqrt(ss / c.time_s.size()), ss / (0.02 * 0.02), c.time_s.size());
  }
  for (int e : {400, 1000, 2000}) {
    RecoveryModelOptions o;
    o.elements = e;
    const RecoveryCurve curve = simulate_recovery(ForwardParameters{}, o);
    std::printf(
        "elements %d: cpu %.2f s, model t_c at eta_ref %.5f s, lambda(0) %.4f, mu %.3f pN/um\n", e,
        curve.cpu_s, curve.recovery_time_s(o.eta_ref_pN_s_per_um), curve.lambda[0],
        curve.shear_modulus_pN_per_um);
    for (RecoveryNuisances nu : {RecoveryNuisances::laplace, RecoveryNuisances::profile}) {
      RecoveryLikelihoodOptions lo;
      lo.nuisances = nu;
      double best = -1e300, best_eta = 0;
      for (double eta = 0.4; eta <= 2.0; eta += 0.005) {
        const double l = recovery_log_likelihood(curve, eta, data, lo);
        if (l > best) {
          best = l;
          best_eta = eta;
        }
      }
      double lo90 = 0, hi90 = 0;
      for (double eta = 0.4; eta <= 2.0; eta += 0.001) {
        const double l = recovery_log_likelihood(curve, eta, data, lo);
        if (l >= best - 1.3528) {
          if (lo90 == 0) lo90 = eta;
          hi90 = eta;
        }
      }
      const RecoveryLikelihood r = evaluate_recovery_likelihood(curve, best_eta, data, lo);
      std::printf("  %s: MLE eta_m %.3f [%.3f, %.3f] logL %.2f t_c %.4f s\n",
                  nu == RecoveryNuisances::laplace ? "laplace" : "profile", best_eta, lo90, hi90,
                  best, curve.recovery_time_s(best_eta));
      for (const auto& f : r.cells)
        std::printf("    cell %d: lambda_0 %.4f lambda_inf %.4f chi2 %.1f\n", f.id, f.lambda_0,
                    f.lambda_inf, f.chi2);
    }
  }
}

// Measurement for docs/validation/recovery_likelihood.md (not run by default): the release
// force's and each cell's share, at the default 1,000 elements.
TEST(RecoveryMeasure, DISABLED_ForceAndCells) {
  const RecoveryData data =
      read_recovery_data(default_data_directory() + "/hochmuth1979_recovery_cells.csv");
  for (bool rich : {false, true}) {
    RecoveryModelOptions o;
    o.richardson = rich;
    const RecoveryCurve c = simulate_recovery(ForwardParameters{}, o);
    std::printf("defaults, extrapolation %d: cpu %.2f s\n", rich, c.cpu_s);
  }
  for (double f : {50.0, 100.0, 150.0}) {
    RecoveryModelOptions o;
    o.release_force_pN = f;
    const RecoveryCurve curve = simulate_recovery(ForwardParameters{}, o);
    const EtaProfile e = eta_profile(curve, data, {});
    std::printf("F %.0f pN: lambda(0) %.3f, MLE eta_m %.3f [%.3f, %.3f], t_c %.4f s, cpu %.2f s\n",
                f, curve.lambda[0], e.mle, e.lo, e.hi, curve.recovery_time_s(e.mle), curve.cpu_s);
    if (f != 100.0) continue;
    for (const RecoveryCell& c : data.cells) {
      RecoveryData one = data;
      one.cells = {c};
      const EtaProfile ec = eta_profile(curve, one, {});
      const RecoveryLikelihood r = evaluate_recovery_likelihood(curve, ec.mle, one);
      std::printf("  cell %d alone: eta_m %.3f [%.3f, %.3f], t_c %.4f s, chi2 %.1f\n", c.id, ec.mle,
                  ec.lo, ec.hi, curve.recovery_time_s(ec.mle), r.cells[0].chi2);
    }
  }
}

}  // namespace
}  // namespace rbc
