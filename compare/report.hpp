#pragma once
// `rbc report`: Fig. 7, the trade-off and the stability map in one Markdown report whose
// every number is traceable to a CSV next to it.
#include <string>

#include "compare/fig7.hpp"
#include "compare/mc_convergence.hpp"
#include "compare/stability.hpp"
#include "compare/tradeoff.hpp"

namespace rbc {

struct ReportOptions {
  Fig7Options fig7;
  TradeoffOptions tradeoff;
  StabilityOptions stability;
  /// Time to the same accuracy, Monte Carlo against the minimiser (written beside the
  /// trade-off chart, in DIR/tradeoff/).
  McConvergenceOptions mc_convergence;
  bool include_mc_convergence = true;
};

/// The paper's claims, checked with numbers.
struct ClaimCheck {
  std::string claim, verdict, evidence;
};

/// Claim checks from the three studies (any may be partial: missing methods are said so).
std::vector<ClaimCheck> check_claims(const Fig7Result& fig7, const TradeoffResult& tradeoff,
                                     const StabilityResult& stability);

/// Runs the three studies into DIR/fig7, DIR/tradeoff, DIR/stability (and the Monte Carlo
/// convergence study into DIR/tradeoff) and writes DIR/report.md.
void run_report(const ReportOptions& options, const std::string& dir, const ProgressSink& progress);

}  // namespace rbc
