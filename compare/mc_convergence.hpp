// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Time to the same accuracy: Monte Carlo against the minimiser for the
// zero-temperature answer of one network at one force.
//
// Both methods start from the rest shape of the same network and are scored against the same
// reference, the minimiser's answer at the default tolerance (1e-3 pN). The minimiser is run
// once per force tolerance (a point per tolerance: wall time of the solve, error); the Monte
// Carlo chain is a quench (T = 0: only downhill single-vertex moves, the trial step adapting
// for the whole run) sampled along its wall-clock budget (a curve). The chain holds the area
// and volume multipliers FIXED at the reference's values, so it is handed the one part of the
// answer a single-vertex move cannot find; its time is therefore a lower bound on a
// self-contained MC solve.
#include <optional>
#include <string>
#include <vector>

#include "discrete/network.hpp"
#include "core/progress.hpp"
#include "discrete/constraint_energy.hpp"
#include "discrete/network.hpp"

namespace rbc {

struct McConvergenceOptions {
  int vertices = 500;  ///< target network size (as `rbc stretch --vertices`)
  double force_pN = 88.0;
  double mc_budget_s = 20.0;      ///< wall-clock budget of the Monte Carlo chain
  double mc_temperature_K = 0.0;  ///< 0 = quench: the zero-temperature answer
  /// Acceptance the trial step adapts to, for the whole run. At T = 0 only downhill moves are
  /// accepted, so acceptance is at most 1/2 (reached as the step -> 0); a target near that
  /// ceiling (the 30-50 % band of finite-temperature sampling) makes the step shrink with the
  /// residual forces and the quench stalls. Measured at N = 492, 88 pN: after 8 s targets 0.3
  /// and 0.35 leave D_A 3.7-3.8 um short, 0.1 and 0.2 within 7e-3 um; at 0.4 the step falls to
  /// 1e-8 um and D_A is still 3.8 um short after 30 s.
  double mc_target_acceptance = 0.1;
  int sample_every_sweeps = 0;  ///< > 0: fixed interval; 0: ~100 log-spaced wall times
  /// > 0: run exactly this many sweeps (fixed work, reproducible; with sample_every_sweeps
  /// > 0 every sample is at a fixed sweep count) instead of the wall-clock budget.
  long long mc_sweeps = 0;
  unsigned long seed = 1;  ///< of the chain's RNG stream
  /// The network's physics (default: paper Tables 1-2).
  NetworkParameters parameters;
  /// From loose to the reference's own: at N ~ 500, 88 pN, 0.1 pN already gives D_A to
  /// ~0.02 %, so the looser ones resolve the minimiser's time at the 10 % to 0.3 % levels.
  std::vector<double> force_tolerances_pN = {3.0, 1.0, 0.3, 0.1, 1e-2, 1e-3};
  /// Accuracy levels of the time-to-accuracy table, as fractions of the reference D_A.
  std::vector<double> relative_accuracies = {0.1, 0.03, 0.01, 0.003};
  /// Throws std::invalid_argument (rbc::InvalidParameter) naming the value, every number
  /// finite: vertices in [100, 40000], force in [0, kMaxDiscreteForce_pN] pN, budget in
  /// (0, kMaxMcBudget_s] s, temperature in [0, 1000] K, target acceptance in (0, 1) and at 0 K
  /// in (0, 0.5), sample interval >= 0, sweep count >= 0 (0 = budget), tolerances in (0, 10] pN
  /// and accuracy levels in (0, 1], both non-empty.
  void validate() const;
};

/// Largest wall-clock budget of the study's Monte Carlo chain (s): one day.
inline constexpr double kMaxMcBudget_s = 86400.0;

enum class ConvergenceKind { minimiser, monte_carlo };

/// One measurement of either method: where it stands after `wall_s` of its own work.
struct ConvergencePoint {
  ConvergenceKind kind = ConvergenceKind::minimiser;
  double wall_s = 0;
  double axial_um = 0, transverse_um = 0;
  double axial_error_um = 0, transverse_error_um = 0;  ///< |value - reference|
  double force_tolerance_pN = 0;                       ///< minimiser: the tolerance of this solve
  int iterations = 0;                                  ///< minimiser: L-BFGS iterations
  bool converged = false;                              ///< minimiser: reached its tolerance
  long long sweeps = 0;                                ///< Monte Carlo: sweeps done
  double step_um = 0;                                  ///< Monte Carlo: current trial step
};

/// The reference answer: the minimiser at the default stretch options from the rest shape.
struct McConvergenceReference {
  double axial_um = 0, transverse_um = 0;
  ConstraintMultipliers multipliers;  ///< handed to the Monte Carlo chain
  double force_tolerance_pN = 0, wall_s = 0, residual_pN = 0;
  bool converged = false;
};

/// Time each method needs to bring |D_A - D_A_ref| to `relative` x D_A_ref (nullopt: not
/// reached, for Monte Carlo within its budget).
struct TimeToAccuracy {
  double relative = 0, level_um = 0;
  std::optional<double> minimiser_s, mc_s;
  std::optional<long long> mc_sweeps;
  /// Monte Carlo time / minimiser time, when both reached the level.
  std::optional<double> ratio() const;
};

struct McConvergenceResult {
  McConvergenceOptions options;
  int vertices = 0;  ///< actual network size
  McConvergenceReference reference;
  std::vector<ConvergencePoint> minimiser;  ///< in the order of options.force_tolerances_pN
  std::vector<ConvergencePoint> mc;         ///< in time order
  double mc_wall_s = 0;                     ///< the chain's actual run time
  std::vector<TimeToAccuracy> time_to_accuracy;
};

/// The earliest point (in wall time) with D_A error <= level_um; nullptr when none. A
/// minimiser point counts only if every tighter tolerance is within the level too (the error
/// falls and stays); for Monte Carlo the first crossing counts.
const ConvergencePoint* first_at_accuracy(const std::vector<ConvergencePoint>& series,
                                          double level_um);

/// The table for the levels of `result.options`, from the series and the reference.
std::vector<TimeToAccuracy> time_to_accuracy_table(const McConvergenceResult& result);

McConvergenceResult run_mc_convergence(const McConvergenceOptions& options,
                                       const ProgressSink& progress);

/// One or two sentences comparing the methods, computed from the table (for reports).
std::string mc_convergence_conclusion(const McConvergenceResult& result);

/// Writes DIR/mc_convergence.csv (both series, `kind` column), mc_convergence.json and the
/// log-log chart mc_convergence.png (with its data files mc_convergence_{mc,minimiser}.csv).
void write_mc_convergence(const McConvergenceResult& result, const std::string& dir);

}  // namespace rbc
