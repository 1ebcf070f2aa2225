// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Accuracy against cost for every method and resolution at one force, measured against a
// stated reference: Richardson extrapolation of the two finest discrete networks.
#include <string>
#include <vector>

#include "compare/methods.hpp"

namespace rbc {

struct TradeoffOptions {
  double force_pN = 88.0;
  std::vector<int> discrete_vertices = {250, 500, 1000, 2000, 4000, 8000, 16000, 27500};
  std::vector<int> continuum_elements = {500, 1000, 2000, 4000, 8000, 16000};
  std::vector<WlcExpansion> continuum_orders = {WlcExpansion::order2, WlcExpansion::full};
  bool include_continuum = true;
  /// The physics of every method (default: paper Tables 1-2).
  NetworkParameters parameters;
  /// Comment lines the written CSV files carry (what produced them: app/run_config.hpp).
  std::vector<std::string> provenance;
};

/// The reference answer and how it was obtained. Discrete D(N) = D_inf + c/N + ...
/// (error ~ h^2 ~ 1/N): D_inf = (N2 D2 - N1 D1)/(N2 - N1) from the two finest networks;
/// its own error is estimated as |D_inf - D2| (the size of the correction).
struct TradeoffReference {
  double axial_um = 0, transverse_um = 0;
  double axial_error_um = 0, transverse_error_um = 0;
  std::string how;
};

struct TradeoffRow {
  MethodRun run;
  double axial_um = 0, transverse_um = 0, wall_s = 0;
  bool converged = false;
  double axial_error_um = 0, transverse_error_um = 0;  ///< |value - reference|
  bool pareto = false;  ///< on the D_A Pareto front: no faster method is more accurate
};

struct TradeoffResult {
  double force_pN = 0;
  TradeoffReference reference;
  std::vector<TradeoffRow> rows;
  std::vector<std::string> provenance;  ///< TradeoffOptions::provenance
};

TradeoffReference richardson_reference(const std::vector<TradeoffRow>& discrete_rows);

/// Marks rows on the Pareto front of (wall time, D_A error) among converged rows.
void mark_pareto_front(std::vector<TradeoffRow>& rows);

TradeoffResult run_tradeoff(const TradeoffOptions& options, const ProgressSink& progress);

/// Writes DIR/tradeoff.csv, tradeoff.json, tradeoff_axial.png and tradeoff_transverse.png.
void write_tradeoff(const TradeoffResult& result, const std::string& dir);

}  // namespace rbc
