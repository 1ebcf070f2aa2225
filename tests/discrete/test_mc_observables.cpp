// Statistics of MC time series: blocking errors against the closed form of an AR(1) process,
// coverage of the error bars, and equilibration detection on a series with a known transient.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

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

TEST(McObservables, BlockingErrorMatchesAr1ClosedForm) {
  for (const double phi : {0.0, 0.5, 0.9, 0.97}) {
    const std::size_t n = 1u << 18;
    const BlockingResult b = blocking_analysis(ar1(n, phi, 17));
    const double g = (1 + phi) / (1 - phi);
    const double exact = std::sqrt(g / double(n));
    EXPECT_TRUE(b.converged) << "phi " << phi;
    EXPECT_NEAR(b.error, exact, 0.12 * exact) << "phi " << phi << ", level " << b.level;
    EXPECT_NEAR(b.inefficiency, g, 0.25 * g) << "phi " << phi;
    EXPECT_NEAR(b.variance, 1.0, 0.05 + 10 * exact);
  }
}

TEST(McObservables, ErrorBarsCoverTheTrueMeanAtTheNominalRate) {
  // 300 independent short chains (tau ~ 10 samples): |mean| < 1 error should hold ~68 % of the
  // time and < 2 errors ~95 %; blocking on 4096 samples is slightly optimistic, not more.
  int one = 0, two = 0;
  const int chains = 300;
  for (int c = 0; c < chains; ++c) {
    const BlockingResult b = blocking_analysis(ar1(4096, 0.9, 1000 + c));
    one += std::abs(b.mean) < b.error;
    two += std::abs(b.mean) < 2 * b.error;
  }
  EXPECT_GT(one, 0.56 * chains);
  EXPECT_LT(one, 0.80 * chains);
  EXPECT_GT(two, 0.88 * chains);
}

TEST(McObservables, ConstantAndTinySeries) {
  const BlockingResult b = blocking_analysis(std::vector<double>(100, 2.5));
  EXPECT_EQ(b.mean, 2.5);
  EXPECT_EQ(b.error, 0.0);
  EXPECT_THROW(blocking_analysis({1.0}), std::invalid_argument);
}

TEST(McObservables, EquilibrationDetectionDiscardsTheTransient) {
  // Transient 5 exp(-t/200) on top of an AR(1) process of mean 0.
  const std::size_t n = 8000;
  std::vector<double> x = ar1(n, 0.5, 23);
  for (std::size_t t = 0; t < n; ++t) x[t] += 5.0 * std::exp(-double(t) / 200.0);
  const EquilibrationResult eq = detect_equilibration(x);
  EXPECT_GE(eq.start, 400u);  // the bias 5 exp(-2) = 0.7 of the noise at 400 must go
  EXPECT_LE(eq.start, n / 2);
  const std::vector<double> tail(x.begin() + static_cast<std::ptrdiff_t>(eq.start), x.end());
  const BlockingResult b = blocking_analysis(tail);
  EXPECT_LT(std::abs(b.mean), 3 * b.error) << "start " << eq.start;
  // Without discarding, the transient biases the mean by sum(5 exp(-t/200))/n = 0.125.
  const BlockingResult all = blocking_analysis(x);
  EXPECT_GT(std::abs(all.mean), 0.1);
  // A stationary series keeps most of its samples.
  const EquilibrationResult st = detect_equilibration(ar1(n, 0.5, 29));
  EXPECT_LE(st.start, n / 4);
}

}  // namespace
}  // namespace rbc
