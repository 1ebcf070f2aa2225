// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/mc_observables.hpp"

#include <gsl/gsl_cdf.h>

#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>

namespace rbc {

BlockingResult blocking_analysis(const std::vector<double>& series) {
  if (series.size() < 2)
    throw std::invalid_argument("blocking analysis needs at least 2 samples, got " +
                                std::to_string(series.size()));
  BlockingResult r;
  r.samples = series.size();
  double mean = 0;
  for (double v : series) mean += v;
  mean /= double(series.size());
  r.mean = mean;
  // Per level: n_j, variance s_j^2 (1/n convention, Jonsson) and lag-1 autocovariance gamma_j.
  std::vector<double> x = series, s2, gamma;
  std::vector<std::size_t> n;
  while (x.size() >= 2) {
    const std::size_t m = x.size();
    double mu = 0;
    for (double v : x) mu += v;
    mu /= double(m);
    double var = 0, cov = 0;
    for (std::size_t i = 0; i < m; ++i) var += (x[i] - mu) * (x[i] - mu);
    for (std::size_t i = 0; i + 1 < m; ++i) cov += (x[i] - mu) * (x[i + 1] - mu);
    n.push_back(m);
    s2.push_back(var / double(m));
    gamma.push_back(cov / double(m));
    const std::size_t off = m % 2;  // drop the earliest value when odd (keep the later data)
    std::vector<double> y((m - off) / 2);
    for (std::size_t i = 0; i < y.size(); ++i) y[i] = 0.5 * (x[off + 2 * i] + x[off + 2 * i + 1]);
    x.swap(y);
  }
  const int levels = static_cast<int>(n.size());
  r.variance = s2[0] * double(n[0]) / double(n[0] - 1);
  if (!(s2[0] > 0)) {  // a constant series: no fluctuation, zero error
    r.error = 0;
    r.inefficiency = 1;
    return r;
  }
  // M_k by a suffix sum; levels whose variance vanished contribute nothing.
  std::vector<double> M(levels + 1, 0.0);
  for (int j = levels - 1; j >= 0; --j) {
    const double t = s2[j] > 0 ? gamma[j] / s2[j] : 0.0;
    M[j] = M[j + 1] + double(n[j]) * t * t;
  }
  int k = 0;
  r.converged = false;
  for (; k < levels; ++k)
    if (M[k] < gsl_cdf_chisq_Pinv(0.99, double(levels - k))) {
      r.converged = true;
      break;
    }
  // The last usable levels have 2-3 blocks; never report a level with fewer than 4 blocks.
  if (!r.converged) k = levels - 1;
  while (k > 0 && n[k] < 4) --k;
  r.level = k;
  r.error = std::sqrt(s2[k] / double(n[k] - 1 > 0 ? n[k] - 1 : 1));
  r.inefficiency = double(r.samples) * r.error * r.error / r.variance;
  r.blocking_error = r.error;
  return r;
}

BlockingResult correlated_mean(const std::vector<double>& series) {
  BlockingResult r = blocking_analysis(series);  // mean, variance, level (same sums)
  r.window = 0;
  const std::size_t n = series.size();
  if (!(r.variance > 0)) return r;  // constant: zero error (blocking_analysis's answer)
  // Autocovariances by FFT, zero-padded to a power of two >= 2n (no wrap-around).
  std::size_t len = 1;
  while (len < 2 * n) len <<= 1;
  std::vector<double> y(len, 0.0);
  for (std::size_t i = 0; i < n; ++i) y[i] = series[i] - r.mean;
  Eigen::FFT<double> fft;
  fft.SetFlag(Eigen::FFT<double>::HalfSpectrum);
  std::vector<std::complex<double>> f;
  fft.fwd(f, y);
  for (std::complex<double>& z : f) z = std::norm(z);
  std::vector<double> c;
  fft.inv(c, f, static_cast<Eigen::Index>(len));  // c[k] = sum_i y_i y_{i+k}
  const auto cov = [&](std::size_t k) { return k < n ? c[k] / double(n) : 0.0; };
  double sum = 0, last = std::numeric_limits<double>::infinity();
  bool ended = false;
  std::size_t j = 0;
  for (; 2 * j + 1 < n; ++j) {
    const double pair = cov(2 * j) + cov(2 * j + 1);
    if (!(pair > 0)) {
      ended = true;
      break;
    }
    last = std::min(last, pair);
    sum += last;
  }
  const double var_mean = std::max(2.0 * sum - cov(0), 0.0) / double(n);
  r.window = static_cast<int>(2 * j);
  r.error = std::sqrt(var_mean);
  r.inefficiency = double(n) * var_mean / r.variance;
  r.converged = ended && double(n) >= kMinEffectiveSamples * r.inefficiency;
  return r;
}

EquilibrationResult detect_equilibration(const std::vector<double>& series, int candidates) {
  if (candidates < 1) throw std::invalid_argument("equilibration candidates must be >= 1");
  const std::size_t n = series.size();
  EquilibrationResult best;
  if (n < 8) {
    best.start = 0;
    best.effective_samples = double(n);
    return best;
  }
  best.effective_samples = -1;
  for (int c = 0; c <= candidates; ++c) {
    const std::size_t t0 = n / 2 * std::size_t(c) / std::size_t(candidates);
    const std::vector<double> tail(series.begin() + static_cast<std::ptrdiff_t>(t0), series.end());
    const BlockingResult b = blocking_analysis(tail);
    const double g = std::max(1.0, b.inefficiency);
    const double eff = double(n - t0) / g;
    if (eff > best.effective_samples) {
      best.effective_samples = eff;
      best.start = t0;
    }
  }
  return best;
}

}  // namespace rbc
