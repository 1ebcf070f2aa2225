// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// `rbc bench infer`: the default calibration by each sampler, side by side in one run.
#include <string>
#include <vector>

namespace rbc::app {

/// Registers infer/default_calibration/sampler:0 (TMCMC) and .../sampler:1 (laplace-is), each
/// run once in real time on the default data file, method and parameters of `rbc infer`, with
/// the forward runs, log evidence (and its error), the effective sample size (laplace-is) and
/// every inferred parameter's and mu's 5, 50 and 95 % quantiles as counters. Appends the family
/// name to `families`.
void register_infer_benchmarks(std::vector<std::string>& families);

}  // namespace rbc::app
