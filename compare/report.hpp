// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// `rbc report`: Fig. 7, the trade-off and the stability map in one Markdown report whose
// every number is traceable to a CSV next to it.
#include <optional>
#include <string>
#include <vector>

#include "compare/accuracy_study.hpp"
#include "compare/fig7.hpp"
#include "compare/mc_convergence.hpp"
#include "compare/stability.hpp"
#include "compare/tradeoff.hpp"

namespace rbc {

/// One cached `rbc infer --out DIR` result as the report reads it (DIR/summary.json; the report
/// never re-runs the inference). Units: natural (nm, J, uN/m, um, pN).
struct CachedCalibration {
  struct Estimate {
    std::string name, unit;
    double mean = 0, sd = 0, q05 = 0, q50 = 0, q95 = 0;
    std::optional<std::pair<double, double>> prior;  ///< uniform prior box, when recorded
  };
  std::string name, label;  ///< directory name; reading label from the index
  std::string dir;          ///< the cache directory read
  std::string method, data_file, command;
  int samples_per_stage = 0, stages = 0;
  std::vector<Estimate> parameters;  ///< persistence, lmax, kappa, contact-fraction, sigma-scale
  Estimate mu, K;                    ///< derived moduli (uN/m)
  double log_evidence = 0, log_evidence_sd = 0;
  long long runs = 0, retried = 0, failed = 0;
  double wall_s = 0;
  // Data as the likelihood saw them (sigma = total, before sigma-scale) and the posterior
  // predictive model curve (5/50/95 %), per force.
  std::vector<double> force_pN, axial_um, axial_sigma_um, transverse_um, transverse_sigma_um;
  std::vector<char> transverse_used;
  std::vector<double> axial_q05, axial_q50, axial_q95, transverse_q05, transverse_q50,
      transverse_q95;
  const Estimate* find(const std::string& parameter) const;
};

/// Reads DIR/summary.json. Throws std::runtime_error naming the file and what is missing or
/// malformed (the CLI exits 2).
CachedCalibration read_cached_calibration(const std::string& dir);

/// The calibration cache: CACHE/index.json lists the readings (each a `rbc infer --out`
/// directory under CACHE) and the model comparison (a reference run and the runs compared
/// with it, all on the same data):
///   {"readings": [{"dir": "suresh2005_default", "label": "..."}, ...],
///    "comparison": {"reference": "suresh2005_p2_E500", "others": ["suresh2005_full_E500", ...]}}
struct CalibrationCache {
  std::string dir;
  std::vector<CachedCalibration> readings;
  std::optional<CachedCalibration> reference;
  std::vector<CachedCalibration> others;
};
/// Reads the index and every summary it names. Throws std::runtime_error (missing or
/// corrupt index, summary or predictive plot), naming the file.
CalibrationCache read_calibration_cache(const std::string& dir);

/// The report's calibration section (Markdown); copies each reading's predictive and corner
/// PNGs into REPORT_DIR/calibration/<name>/ and links them.
std::string calibration_section(const CalibrationCache& cache, const std::string& report_dir);

struct ReportOptions {
  Fig7Options fig7;
  TradeoffOptions tradeoff;
  StabilityOptions stability;
  /// Time to the same accuracy, Monte Carlo against the minimiser (written beside the
  /// trade-off chart, in DIR/tradeoff/).
  McConvergenceOptions mc_convergence;
  bool include_mc_convergence = true;
  /// Cached calibration results (read_calibration_cache); empty = default_data_directory()
  /// + "/calibration". Read before any study runs, so a bad cache fails first.
  std::string calibration_cache;
  bool include_calibration = true;
};

/// The paper's claims, checked with numbers.
struct ClaimCheck {
  std::string claim, verdict, evidence;
};

/// Claim checks from the three studies (any may be partial: missing methods are said so).
std::vector<ClaimCheck> check_claims(const Fig7Result& fig7, const TradeoffResult& tradeoff,
                                     const StabilityResult& stability);
/// The same; claim 3 (continuum cheaper at equal accuracy) from the committed 13-force
/// accuracy-cost table when `accuracy` is given, per force range at 1 % and 2 %.
std::vector<ClaimCheck> check_claims(const Fig7Result& fig7, const TradeoffResult& tradeoff,
                                     const StabilityResult& stability,
                                     const AccuracyCostTable* accuracy);

/// Runs the three studies into DIR/fig7, DIR/tradeoff, DIR/stability (and the Monte Carlo
/// convergence study into DIR/tradeoff) and writes DIR/report.md.
void run_report(const ReportOptions& options, const std::string& dir, const ProgressSink& progress);

/// The calibration section alone in DIR/report.md (`rbc report --calibration-only`).
void run_calibration_report(const std::string& cache_dir, const std::string& dir);

}  // namespace rbc
