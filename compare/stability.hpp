// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Where each method stops working, found by sweeps rather than asserted:
// Taylor orders against the full WLC, solver budgets at extreme forces, the discrete
// answer against triangle quality, the steric regularisation, and the coarsest
// resolutions that still give 1 % and 5 % (from a trade-off study).
#include <optional>
#include <string>
#include <vector>

#include "compare/tradeoff.hpp"
#include "core/progress.hpp"

namespace rbc {

struct StabilityOptions {
  int discrete_vertices = 1000;   ///< network for the discrete sweeps
  int continuum_elements = 2000;  ///< mesh for the continuum sweeps
  /// Force ladder (pN) for the order-departure sweep, continuation in this order.
  std::vector<double> order_forces_pN = {0, 50, 100, 150, 200, 250, 300, 400, 500};
  /// Halvings of a failing force increment allowed to the continuum solver in the sweeps
  /// (small: a law or solver that fails is itself the finding, and must not stall the study).
  int continuum_bisections = 2;
  /// Force ladder (pN) for the solver-budget sweep.
  std::vector<double> budget_forces_pN = {200, 500, 1000, 2000, 5000};
  int discrete_iteration_budget = 20000;  ///< L-BFGS iterations per force
  std::vector<double> etas = {5e-2, 5e-3, 5e-4, 5e-5};
  std::vector<double> qs = {1.0, 2.0};
  double steric_force_pN = 88.0;
  bool include_continuum = true;
  /// Monte Carlo limits: a small network (vertices) sampled at 0 pN for `mc_sweeps`
  /// production sweeps, with fixed trial steps (um) at 300 K and with adaptive steps at
  /// the temperatures (K).
  int mc_vertices = 300;
  int mc_sweeps = 300;
  std::vector<double> mc_steps_um = {0.001, 0.003, 0.01, 0.03, 0.1};
  std::vector<double> mc_temperatures_K = {30, 300, 3000, 30000};
  bool include_monte_carlo = true;
};

/// Which sweep a row comes from.
enum class StabilityStudy {
  taylor_order,
  solver_budget,
  mesh_quality,
  steric,
  monte_carlo,
  resolution
};

/// What a row measures; the name (to_string) is the CSV/JSON key and carries the unit.
enum class StabilityMetric {
  departure_force_pN,            ///< first force where D_A departs from the full law by a fraction
  unphysical_from_force_pN,      ///< first force with a link past Lmax or no convergence
  max_link_stretch_L_over_Lmax,  ///< largest L/Lmax at the top force
  converged,                     ///< 1 or 0
  iterations,                    ///< solver iterations
  zero_force_axial_change,       ///< relative D_A change in the zero-force relaxation
  axial_um_at_88pN,
  largest_rest_inplane_force_pN,
  K_closed_pN_per_um,
  axial_um_at_force,
  transverse_um_at_force,
  acceptance,
  energy_inefficiency,  ///< statistical inefficiency of the energy series (sweeps)
  axial_shift_um,
  axial_std_um,
  max_area_drift,
  coarsest_resolution,  ///< vertices or elements
};

std::string to_string(StabilityStudy s);
std::string to_string(StabilityMetric m);

/// One measured fact: study, method, a parameter and a metric, with a note. `value` is empty
/// when the sweep did not reach what the metric looks for (written "not reached", never inf
/// or NaN).
struct StabilityRow {
  StabilityStudy study = StabilityStudy::taylor_order;
  std::string method, parameter;
  double parameter_value = 0;
  StabilityMetric metric = StabilityMetric::converged;
  std::optional<double> value;
  std::string note;
};

/// D_A against force for each order and the full law (for the plot).
struct OrderCurve {
  std::string order;
  std::vector<double> force_pN, axial_um, transverse_um, max_link_stretch;
  std::vector<bool> converged;
};

struct StabilityResult {
  std::vector<StabilityRow> rows;
  std::vector<OrderCurve> orders;
};

StabilityResult run_stability(const StabilityOptions& options, const TradeoffResult* tradeoff,
                              const ProgressSink& progress);

/// Coarsest resolution of each method family within `tolerance` (relative, D_A) of the
/// trade-off reference; appended as rows of study "resolution".
void add_resolution_rows(const TradeoffResult& tradeoff, double tolerance,
                         std::vector<StabilityRow>& rows);

/// Writes DIR/stability.csv, stability.json and stability_orders.png.
void write_stability(const StabilityResult& result, const std::string& dir);

}  // namespace rbc
