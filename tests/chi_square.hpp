// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Pearson's chi-square of histogram counts against bin probabilities, for the statistical law
// tests (a test that can fail: compare with gsl_cdf_chisq_Qinv(alpha, dof)).
#include <cstddef>
#include <vector>

namespace rbc::testing {

/// sum over bins with an expected count of at least 5 of (count - expected)^2 / expected;
/// *dof = those bins less one. Bins are chosen so that none is that small; the cut is a guard.
inline double chi_square(const std::vector<long>& count, const std::vector<double>& probability,
                         long samples, int* dof) {
  double chi2 = 0;
  *dof = -1;
  for (std::size_t b = 0; b < count.size(); ++b) {
    const double e = probability[b] * double(samples);
    if (e < 5) continue;
    chi2 += (double(count[b]) - e) * (double(count[b]) - e) / e;
    ++*dof;
  }
  return chi2;
}

}  // namespace rbc::testing
