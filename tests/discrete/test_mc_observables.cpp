// SPDX-License-Identifier: GPL-3.0-or-later
// Statistics of MC time series: blocking and autocorrelation-time errors against the closed form
// of an AR(1) process, coverage of the error bars, and equilibration detection on a series with
// a known transient. Every statistical check states its false-alarm probability per run, derived
// from exact distributions (binomial, normal) with the estimators' own behaviour (bias, scatter,
// coverage) measured on 4,000-100,000 AR(1) series of seeds other than the tests'; each test's
// total, the sum over its checks (Bonferroni), is at most 1e-3.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "discrete/mc_observables.hpp"

namespace rbc {
namespace {

// x_t = phi x_{t-1} + sqrt(1 - phi^2) e_t: unit variance, and the variance of the mean of n
// samples is (1/n)(1 + phi)/(1 - phi) for n >> 1/(1 - phi) (statistical inefficiency g).
std::vector<double> ar1(std::size_t n, double phi, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> e(0.0, 1.0);
  std::vector<double> x(n);
  double v = e(rng);
  for (std::size_t t = 0; t < n; ++t) {
    v = phi * v + std::sqrt(1 - phi * phi) * e(rng);
    x[t] = v;
  }
  return x;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(McObservables, BlockingErrorMatchesAr1ClosedForm) {
  // One series is not enough: blocking's chosen level now and then lands late (few blocks), so
  // error/exact has heavy tails. Over 4,000 series per phi (n = 2^18) error/exact falls outside
  // [0.88, 1.12] with probability q = 5e-4, 1.3e-3, 1.3e-3, 6.3e-3 (phi 0, 0.5, 0.9, 0.97; its
  // median 1.000, 0.979, 0.963, 0.936: blocking runs low as phi grows) and inefficiency/g outside
  // [0.75, 1.25] with q <= 1.3e-3. The median of 5 series leaves a band only if 3 of the 5 do:
  // P <= C(5,3) q^3 = 2.5e-6 at q = 6.3e-3 (1.4e-5 at the 99.9 % upper limit of q, 0.011), so
  // < 1e-4 over the 8 median checks. The sample variance of 2^18 values is normal with sd
  // sqrt(2 (1 + phi^2) / ((1 - phi^2) n)) <= 0.016: its band is >= 13 sd (P < 1e-30). converged
  // is not random: the last level (2 or 3 blocks) always passes Jonsson's test (M <= 3, below
  // 6.63, the 99 % quantile of chi^2 with 1 degree of freedom).
  // Detects an error bar or inefficiency off by more than ~12 % (~25 %) in the median.
  for (const double phi : {0.0, 0.5, 0.9, 0.97}) {
    const std::size_t n = 1u << 18;
    const double g = (1 + phi) / (1 - phi);
    const double exact = std::sqrt(g / double(n));
    std::vector<double> error_ratio, inefficiency_ratio;
    for (unsigned seed = 17; seed < 22; ++seed) {
      const BlockingResult b = blocking_analysis(ar1(n, phi, seed));
      EXPECT_TRUE(b.converged) << "phi " << phi;
      EXPECT_NEAR(b.variance, 1.0, 0.05 + 10 * exact) << "phi " << phi << " seed " << seed;
      error_ratio.push_back(b.error / exact);
      inefficiency_ratio.push_back(b.inefficiency / g);
    }
    EXPECT_NEAR(median(error_ratio), 1.0, 0.12) << "phi " << phi;
    EXPECT_NEAR(median(inefficiency_ratio), 1.0, 0.25) << "phi " << phi;
  }
}

TEST(McObservables, ErrorBarsCoverTheTrueMeanAtTheNominalRate) {
  // 2,000 independent short chains (g = 19, 4,096 samples: 215 effective samples): blocking is
  // optimistic here, its error bars cover the true mean 0 with |mean| < 1 error in 60.55 % and
  // < 2 errors in 90.76 % of the chains (100,000 chains; standard errors 0.15 % and 0.09 %;
  // nominal 68.3 % and 95.4 %). The counts are binomial: with the rates at the ends of their
  // 99.9 % intervals, P(one <= 1,100) = 2.6e-6, P(one >= 1,320) = 2.8e-6 and P(two <= 1,760) =
  // 1.7e-4: 1.8e-4 over the test. Detects a 2-error coverage below ~87 % or a 1-error coverage
  // outside ~[54 %, 67 %].
  int one = 0, two = 0;
  const int chains = 2000;
  for (int c = 0; c < chains; ++c) {
    const BlockingResult b = blocking_analysis(ar1(4096, 0.9, 1000 + c));
    one += std::abs(b.mean) < b.error;
    two += std::abs(b.mean) < 2 * b.error;
  }
  EXPECT_GT(one, 0.55 * chains);
  EXPECT_LT(one, 0.66 * chains);
  EXPECT_GT(two, 0.88 * chains);
}

TEST(McObservables, ConstantAndTinySeries) {
  const BlockingResult b = blocking_analysis(std::vector<double>(100, 2.5));
  EXPECT_EQ(b.mean, 2.5);
  EXPECT_EQ(b.error, 0.0);
  EXPECT_THROW(blocking_analysis({1.0}), std::invalid_argument);
}

TEST(McObservables, EquilibrationDetectionDiscardsTheTransient) {
  // Transient 5 exp(-t/200) on top of an AR(1) process of mean 0 (phi 0.5, g = 3). The rates
  // quoted below were measured on 34,000 series of other seeds (174,000 for the start).
  const std::size_t n = 8000;
  auto transient = [](std::size_t t) { return 5.0 * std::exp(-double(t) / 200.0); };
  std::vector<double> x = ar1(n, 0.5, 23);
  for (std::size_t t = 0; t < n; ++t) x[t] += transient(t);
  const EquilibrationResult eq = detect_equilibration(x);
  // The bias 5 exp(-2) = 0.7 of the noise at 400 must go. The candidates are 0, 200, ..., n/2;
  // start <= 200 was chosen in 4 of 174,000 series (P = 2.3e-5, < 8.5e-5 at 99.9 %
  // confidence); start <= n/2 holds by construction.
  EXPECT_GE(eq.start, 400u);
  EXPECT_LE(eq.start, n / 2);
  // The kept tail's mean against its exact expectation, the transient left after the start
  // (at most sum_{t >= 400} 5 exp(-t/200) / 7,600 = 0.018), in units of its blocking error: over
  // the series that z has mean -0.05 and sd 1.06, and its tails follow that normal law
  // (P(|z| > 3) 4.9e-3, P(|z| > 4) 2.5e-4 measured; 4.8e-3 and 1.7e-4 predicted), so
  // P(|z| >= 4.5) = 2.3e-5. A coarse check (an error bar 3 times too small fails it with
  // probability ~0.16); start >= 400 above is the check on the detection itself.
  const std::vector<double> tail(x.begin() + static_cast<std::ptrdiff_t>(eq.start), x.end());
  const BlockingResult b = blocking_analysis(tail);
  double left = 0;
  for (std::size_t t = eq.start; t < n; ++t) left += transient(t);
  left /= double(n - eq.start);
  EXPECT_LT(std::abs(b.mean - left), 4.5 * b.error) << "start " << eq.start;
  // Without discarding, the transient biases the mean by sum(5 exp(-t/200))/n = 0.1253; the mean
  // of all n samples is exactly normal with that mean and sd sqrt(3/n) = 0.0194 (the AR(1) error
  // of the mean), so P(mean <= 0.04) = Phi(-4.4) = 5e-6.
  const BlockingResult all = blocking_analysis(x);
  EXPECT_GT(all.mean, 0.04);
  // Stationary series keep most of their samples: one of them discards more than n/4 with
  // probability q = 9e-4 (31 of 33,800; q < 1.5e-3 at 99.9 % confidence), so 4 of 5 must keep
  // 3n/4: P(2 or more of 5 fail) <= 10 q^2 = 2.3e-5. Over the test: < 2e-4.
  int kept = 0;
  for (unsigned seed = 29; seed < 34; ++seed)
    kept += detect_equilibration(ar1(n, 0.5, seed)).start <= n / 4;
  EXPECT_GE(kept, 4);
}

// Exact standard error of the mean of n samples of the unit-variance AR(1) process above:
// var = (1/n) [g - 2 phi (1 - phi^n) / (n (1 - phi)^2)], g = (1 + phi)/(1 - phi).
double ar1_exact_error(std::size_t n, double phi) {
  const double dn = double(n);
  const double g = (1 + phi) / (1 - phi);
  return std::sqrt((g - 2 * phi * (1 - std::pow(phi, dn)) / (dn * (1 - phi) * (1 - phi))) / dn);
}

TEST(McObservables, CorrelatedMeanErrorMatchesAr1ClosedForm) {
  // 16 seeds per case, n = 2^15 samples, n/g from 165 (phi 0.99) to 3.3e4 (independent). Over
  // 4,000 series per case (7,000 at phi 0.99) error/exact has mean 1.004, 1.004, 1.005, 1.003
  // and sd 0.009, 0.018, 0.041, 0.119 (skewed to the right at phi 0.99: skewness 0.95), so the
  // seed mean has se = 0.0024, 0.0045, 0.010, 0.030 and tol is 6.6, 5.9, 7.3, 5.3 se from the
  // measured mean; its tail probabilities, by resampling 16 of the measured ratios 4e6 times:
  // 0, 0, 0, 6.5e-6. converged needs n/g >= 50: at phi 0.99 error/exact < ~1.81, never missed
  // in 7,000 series (largest 1.78; q < 1e-3 at 99.9 % confidence); below it n/g >= 1,700.
  // One of 16 may miss: P(2 or more) <= 120 q^2 = 1.2e-4. Over the test: < 2e-4. Detects a
  // mean error off by more than tol + 3 se (0.03, 0.04, 0.11, 0.25). The inefficiency identity
  // is exact arithmetic.
  const std::pair<double, double> cases[] = {{0.0, 0.02}, {0.5, 0.03}, {0.9, 0.08}, {0.99, 0.16}};
  for (const auto& [phi, tol] : cases) {
    const std::size_t n = 1u << 15;
    const double exact = ar1_exact_error(n, phi);
    double ratio_sum = 0;
    int not_converged = 0;
    const unsigned seeds = 16;
    for (unsigned seed = 0; seed < seeds; ++seed) {
      const BlockingResult b = correlated_mean(ar1(n, phi, 300 + seed));
      not_converged += !b.converged;
      EXPECT_NEAR(b.inefficiency, double(n) * b.error * b.error / b.variance,
                  1e-9 * b.inefficiency);
      ratio_sum += b.error / exact;
    }
    EXPECT_NEAR(ratio_sum / seeds, 1.0, tol) << "phi " << phi;
    EXPECT_LE(not_converged, 1) << "phi " << phi;
  }
}

TEST(McObservables, CorrelatedMeanCoversTheTrueMeanInTheMonteCarloRegime) {
  // The regime of `rbc mc` (series ~50 autocorrelation times long): 1,200 chains of AR(1) with
  // g = 199, n = 10,000. |mean| < 2 errors must hold at close to the nominal 95 %: measured
  // 93.41 % with this estimator (|mean| < 1 error: 66.02 %, not converged: 35.8 %; 50,000 chains,
  // standard errors 0.11 %, 0.21 %, 0.21 %), 85.5 % with blocking_analysis (Jonsson's level comes
  // before the plateau). The counts are binomial; with the rates at the ends of their 99.9 %
  // intervals P(two <= 1,080) = 5.4e-5, P(two >= 1,170) = 1.5e-9, P(one <= 720) = 7.1e-5,
  // P(one >= 876) = 1.5e-6, and not_converged = 0 or = 1,200 has P < 1e-200: 1.3e-4 over the
  // test. blocking_analysis passes the 90 % threshold with probability 1.4e-6.
  const int chains = 1200;
  const double phi = 0.99;
  const std::size_t n = 10000;
  int one = 0, two = 0, not_converged = 0;
  for (int c = 0; c < chains; ++c) {
    const BlockingResult b = correlated_mean(ar1(n, phi, 5000 + c));
    one += std::abs(b.mean) < b.error;
    two += std::abs(b.mean) < 2 * b.error;
    not_converged += !b.converged;
  }
  EXPECT_GT(two, 0.90 * chains);
  EXPECT_LT(two, 0.975 * chains);  // not inflated either
  EXPECT_GT(one, 0.60 * chains);   // nominal 68.3 %
  EXPECT_LT(one, 0.73 * chains);
  // n/g = 50 = kMinEffectiveSamples: the flag is set about as often as the estimate runs high.
  EXPECT_GT(not_converged, 0);
  EXPECT_LT(not_converged, chains);
}

TEST(McObservables, CorrelatedMeanFlagsSeriesTooShortForTheirCorrelationTime) {
  // g = 999, n = 10,000: 10 effective samples, below kMinEffectiveSamples; the inefficiency
  // would have to be underestimated fivefold to pass the flag, which happened in 3 of 50,000
  // series (q = 6e-5; 2.6e-4 at the 99.9 % upper limit). At most one of 8 may pass:
  // P(2 or more) <= 28 q^2 = 1.9e-6 at the upper limit. Without the flag all 8 would pass.
  int passed = 0;
  for (unsigned seed = 0; seed < 8; ++seed)
    passed += correlated_mean(ar1(10000, 0.998, 70 + seed)).converged;
  EXPECT_LE(passed, 1);
  const BlockingResult b = correlated_mean(std::vector<double>(100, 2.5));
  EXPECT_EQ(b.mean, 2.5);
  EXPECT_EQ(b.error, 0.0);
  EXPECT_THROW(correlated_mean({1.0}), std::invalid_argument);
  // The same mean as blocking_analysis, bit for bit (the Monte Carlo means do not move).
  const std::vector<double> x = ar1(1000, 0.7, 3);
  EXPECT_EQ(correlated_mean(x).mean, blocking_analysis(x).mean);
}

}  // namespace
}  // namespace rbc
