// SPDX-License-Identifier: GPL-3.0-or-later
// The arithmetic of held-out prediction (calibrate/predictive.hpp): quantiles of weighted
// samples and of Gaussian mixtures against values worked out by hand or in closed form, the
// systematic resampling of posterior draws, and the coverage count.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <stdexcept>
#include <vector>

#include "calibrate/predictive.hpp"

namespace rbc {
namespace {

// A weighted sample (every sd 0): values 3, 1, 2 with weights 0.3, 0.2, 0.5. Sorted: 1 (0.2),
// 2 (0.5), 3 (0.3); cumulative 0.2, 0.7, 1.0. The q-quantile is the smallest value whose
// cumulative weight reaches q.
TEST(PredictiveQuantile, WeightedSampleInvertsItsStepCdf) {
  const std::vector<double> x = {3, 1, 2}, sd = {0, 0, 0}, w = {0.3, 0.2, 0.5};
  const struct {
    double q, expect;
  } cases[] = {{0.05, 1}, {0.2, 1}, {0.21, 2}, {0.5, 2}, {0.7, 2}, {0.71, 3}, {0.95, 3}};
  for (const auto& c : cases) EXPECT_NEAR(mixture_quantile(x, sd, w, c.q), c.expect, 1e-9) << c.q;
  // Weights are relative: scaled by 7 they give the same quantiles; an integer weight is the
  // same as repeating the value.
  const std::vector<double> w7 = {2.1, 1.4, 3.5};
  for (double q : {0.1, 0.3, 0.69, 0.8})
    EXPECT_NEAR(mixture_quantile(x, sd, w7, q), mixture_quantile(x, sd, w, q), 1e-9) << q;
  const std::vector<double> xr = {3, 3, 3, 1, 1, 2, 2, 2, 2, 2}, sdr(10, 0.0), wr(10, 1.0);
  for (double q : {0.1, 0.25, 0.5, 0.75, 0.9})
    EXPECT_NEAR(mixture_quantile(xr, sdr, wr, q), mixture_quantile(x, sd, w, q), 1e-9) << q;
}

// One Gaussian: the quantiles are mean + z_q sd with the standard normal quantiles z_q.
TEST(PredictiveQuantile, OneGaussianGivesItsNormalQuantiles) {
  const std::vector<double> m = {10.0}, s = {0.5}, w = {1.0};
  const struct {
    double q, z;
  } cases[] = {{0.05, -1.6448536269514729},
               {0.25, -0.6744897501960817},
               {0.5, 0.0},
               {0.75, 0.6744897501960817},
               {0.95, 1.6448536269514729}};
  for (const auto& c : cases)
    EXPECT_NEAR(mixture_quantile(m, s, w, c.q), 10.0 + 0.5 * c.z, 1e-10) << c.q;
}

// A weighted two-component mixture: the quantile found satisfies the closed-form CDF
// F(x) = sum w_i Phi((x - m_i)/s_i) / sum w_i = q, and the symmetric mixture's median is its
// centre.
TEST(PredictiveQuantile, MixtureQuantileSolvesTheClosedFormCdf) {
  const std::vector<double> m = {1.0, 4.0}, s = {0.3, 1.2}, w = {3.0, 1.0};
  const auto cdf = [&](double x) {
    double f = 0;
    for (int i = 0; i < 2; ++i) f += w[i] * 0.5 * std::erfc(-(x - m[i]) / (s[i] * std::sqrt(2.0)));
    return f / 4.0;
  };
  for (double q : {0.05, 0.25, 0.5, 0.75, 0.9, 0.95}) {
    const double x = mixture_quantile(m, s, w, q);
    EXPECT_NEAR(cdf(x), q, 1e-12) << q;
  }
  // q = 0.75 is the first component's whole mass; its quantile lies between the two means.
  const double x75 = mixture_quantile(m, s, w, 0.75);
  EXPECT_GT(x75, 1.0);
  EXPECT_LT(x75, 4.0);
  const std::vector<double> sym = {-2.0, 2.0}, ssym = {1.0, 1.0}, wsym = {1.0, 1.0};
  EXPECT_NEAR(mixture_quantile(sym, ssym, wsym, 0.5), 0.0, 1e-10);
  // A zero weight leaves its component out.
  const std::vector<double> m3 = {1.0, 4.0, 100.0}, s3 = {0.3, 1.2, 0.1}, w3 = {3.0, 1.0, 0.0};
  EXPECT_NEAR(mixture_quantile(m3, s3, w3, 0.95), mixture_quantile(m, s, w, 0.95), 1e-10);
}

TEST(PredictiveQuantile, RefusesBadInput) {
  const std::vector<double> one = {1.0}, zero = {0.0}, neg = {-1.0};
  EXPECT_THROW(mixture_quantile(one, one, zero, 0.5), std::invalid_argument);  // no weight
  EXPECT_THROW(mixture_quantile(one, neg, one, 0.5), std::invalid_argument);   // sd < 0
  EXPECT_THROW(mixture_quantile(one, one, neg, 0.5), std::invalid_argument);   // weight < 0
  EXPECT_THROW(mixture_quantile(one, one, one, 1.0), std::invalid_argument);   // q = 1
  EXPECT_THROW(mixture_quantile({}, {}, {}, 0.5), std::invalid_argument);
}

// Systematic resampling: each index appears floor(N w_i / W) or that plus one times; the same
// seed gives the same draws, another seed other ones; equal weights and N = size give every
// index once.
TEST(PredictiveDraws, SystematicResamplingKeepsTheWeightsAndTheSeed) {
  const std::vector<double> w = {0.5, 0.0, 2.0, 1.0, 0.25, 3.25};  // total 7
  const int n = 40;
  const std::vector<int> a = predictive_draws(w, n, 11);
  ASSERT_EQ(a.size(), static_cast<size_t>(n));
  std::map<int, int> count;
  for (int i : a) ++count[i];
  for (size_t i = 0; i < w.size(); ++i) {
    const double expect = n * w[i] / 7.0;
    EXPECT_GE(count[static_cast<int>(i)], std::floor(expect)) << i;
    EXPECT_LE(count[static_cast<int>(i)], std::ceil(expect)) << i;
  }
  EXPECT_EQ(count[1], 0);
  EXPECT_EQ(a, predictive_draws(w, n, 11));
  bool differs = false;
  for (std::uint64_t seed = 12; seed < 20 && !differs; ++seed)
    differs = predictive_draws(w, n, seed) != a;
  EXPECT_TRUE(differs);
  const std::vector<double> equal(7, 1.0);
  const std::vector<int> all = predictive_draws(equal, 7, 3);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(all[i], i);
  EXPECT_THROW(predictive_draws(w, 0, 1), std::invalid_argument);
  EXPECT_THROW(predictive_draws(std::vector<double>{0.0, 0.0}, 3, 1), std::invalid_argument);
}

// Coverage counts a point on the band's edge as inside, the 0 pN point once (as D_A).
TEST(PredictiveCoverage, CountsPointsInsideTheBands) {
  DiameterData d;
  d.force_pN = {0, 10, 20};
  d.axial_um = {8.0, 9.0, 12.0};
  d.transverse_um = {8.0, 7.0, 3.0};
  d.axial_sigma_um = d.transverse_sigma_um = {1, 1, 1};
  d.transverse_used = {0, 1, 1};
  PredictiveBand a, t;
  a.q05 = {7, 8, 9};
  a.q25 = {7.5, 9, 10};
  a.q75 = {8.5, 9.5, 11};
  a.q95 = {9, 10, 12};
  t.q05 = {0, 6, 4};
  t.q25 = {0, 6.5, 4.5};
  t.q75 = {0, 7.5, 5.5};
  t.q95 = {0, 8, 6};
  const PredictiveCoverage c = predictive_coverage(d, a, t);
  EXPECT_EQ(c.axial_points, 3);
  EXPECT_EQ(c.transverse_points, 2);
  EXPECT_EQ(c.axial_in_50, 2);  // 8 in [7.5, 8.5], 9 on the edge of [9, 9.5]; 12 above 11
  EXPECT_EQ(c.axial_in_90, 3);  // 12 on the edge of [9, 12]
  EXPECT_EQ(c.transverse_in_50, 1);
  EXPECT_EQ(c.transverse_in_90, 1);  // 3 below 4
  EXPECT_DOUBLE_EQ(c.fraction_50(), 3.0 / 5);
  EXPECT_DOUBLE_EQ(c.fraction_90(), 4.0 / 5);
}

}  // namespace
}  // namespace rbc
