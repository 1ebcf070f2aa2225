#pragma once
// Statistics of Monte Carlo time series with honest errors: the standard error of a mean of
// correlated samples by blocking (Flyvbjerg & Petersen 1989, J. Chem. Phys. 91, 461) with the
// automatic block-level choice of Jonsson (2018, Phys. Rev. E 98, 043304), and equilibration
// detection by maximising the effective sample count (Chodera 2016, JCTC 12, 1799).
#include <cstddef>
#include <vector>

namespace rbc {

/// Mean of a correlated series and its standard error from blocking.
struct BlockingResult {
  double mean = 0;
  double error = 0;     ///< standard error of the mean at the chosen block level
  double variance = 0;  ///< sample variance of the series
  /// Statistical inefficiency g = n error^2 / variance (1 for independent samples; the
  /// integrated autocorrelation time is tau_int = g / 2 in the convention tau_int(iid) = 1/2).
  double inefficiency = 1;
  int level = 0;          ///< chosen blocking level (block length 2^level)
  bool converged = true;  ///< false: no level passed the test (the error is a lower bound)
  std::size_t samples = 0;
};

/// Blocking analysis of `series` (>= 2 values; throws std::invalid_argument otherwise). At
/// each level the series is halved by averaging neighbour pairs (an odd leading value is
/// dropped). The chosen level is the first k for which
///   M_k = sum_{j >= k} n_j (gamma_j / s_j^2)^2
/// (gamma_j the lag-1 autocovariance, s_j^2 the variance at level j) lies below the 99 %
/// quantile of chi-square with (levels - k) degrees of freedom, i.e. the blocks are
/// uncorrelated; error^2 = s_k^2 / (n_k - 1) (Flyvbjerg-Petersen's unbiased form).
BlockingResult blocking_analysis(const std::vector<double>& series);

/// Equilibration detection: the start index t0, among `candidates` evenly spaced values in
/// [0, n/2], that maximises the effective sample count (n - t0) / g(t0), with g the blocking
/// inefficiency of series[t0:]. Samples before t0 are discarded as the transient.
struct EquilibrationResult {
  std::size_t start = 0;
  double effective_samples = 0;
};
EquilibrationResult detect_equilibration(const std::vector<double>& series, int candidates = 20);

}  // namespace rbc
