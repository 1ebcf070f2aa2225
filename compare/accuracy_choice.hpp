// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// `rbc stretch --accuracy P%`: the cheapest method and resolution of the committed trade-off
// table (data/tradeoff/accuracy_by_force.csv, written by `rbc tradeoff --accuracy-table`)
// whose accuracy over the requested forces meets P.
#include <optional>
#include <string>
#include <vector>

#include "compare/methods.hpp"

namespace rbc {

/// One method of the table with its per-force errors (fractions, not %).
struct AccuracyEntry {
  Method method;
  Symmetry symmetry = Symmetry::none;  ///< solver path the cost was measured with
  bool converged = false;
  double cost_eg = 0;  ///< energy+gradient evaluations of the cost unit for the 13-force sweep
  std::vector<double> forces_pN, error;  ///< increasing forces; max rel. error of D_A, D_T
};

struct AccuracyTable {
  std::vector<AccuracyEntry> entries;
  /// Relative standard error of the reference itself: added to every entry's error before
  /// comparing with P, so a choice never rests on a difference the reference cannot resolve.
  double reference_relative_se = 0;
  std::string source;  ///< file name, for messages
};

/// Reads accuracy_by_force.csv (columns kind, order, resolution, converged, cost_eg,
/// force_pN, error, reference_se, symmetry: 0 none, 1 mirror; a table without the last
/// column is all Symmetry::none); throws std::runtime_error naming the file when it is
/// missing, malformed, or its rows are not grouped by method with increasing forces.
AccuracyTable load_accuracy_table(const std::string& path);

/// load_accuracy_table and, when accuracy_by_force_adapted.csv, accuracy_by_force_refined.csv or
/// accuracy_by_force_loop.csv lie beside `path` (the rows of the continuum model on the adapted
/// or the refined mesh, AccuracyStudyOptions::adapted_elements and refined_elements: the same
/// columns and size_ratio; the Loop element's, AccuracyStudyOptions::loop_elements: the same,
/// size_ratio 1), their entries too (Method::adapted, Method::refined, Method::loop). Throws
/// std::runtime_error as load_accuracy_table, or if a file's reference_se differs from the table's.
AccuracyTable load_accuracy_table_with_adapted(const std::string& path);

/// Default table: <data directory>/tradeoff/accuracy_by_force.csv.
std::string default_accuracy_table_path();

/// "1%", "0.5 %" or "2" -> percent (1, 0.5, 2). Throws std::invalid_argument unless the text
/// is a finite number > 0 and <= 100 with an optional trailing '%'.
double parse_accuracy_percent(const std::string& text);

/// An entry's accuracy over a list of forces: the largest error at the requested forces,
/// where a force between two table forces takes the larger error of the two (a table force
/// itself takes its own). Throws std::invalid_argument if a force lies outside the table.
double entry_error(const AccuracyEntry& entry, const std::vector<double>& forces_pN);

struct AccuracyPick {
  Method method;
  Symmetry symmetry = Symmetry::none;  ///< run it with this solver path (`--symmetry`)
  double error = 0;                    ///< over the requested forces (fraction)
  double cost_eg = 0;                  ///< from the table
};

struct AccuracyChoice {
  AccuracyPick chosen;
  /// Next cheapest entry meeting P of another discretisation (the chosen mesh on the other
  /// solver path is skipped).
  std::optional<AccuracyPick> runner_up;
  /// Cheapest entry of the other model kind meeting P, if it is not the runner-up.
  std::optional<AccuracyPick> other_kind;
  double percent = 0;
  double reference_relative_se = 0;
  std::string reason;  ///< one line: what was chosen and why
};

/// The cheapest converged entry with entry_error + reference_relative_se <= percent / 100
/// (ties: smaller error, then table order), among the entries of solver path `only` when
/// given (a user's explicit `--symmetry`). Throws std::invalid_argument (one line) if
/// percent is not finite and > 0, the force list is empty, a force lies outside the table's
/// range, or no entry reaches the percentage (naming the best the table offers).
AccuracyChoice choose_by_accuracy(const AccuracyTable& table, const std::vector<double>& forces_pN,
                                  double percent, std::optional<Symmetry> only = std::nullopt);

/// "discrete:N", "continuum:ORDER:ELEMENTS", "continuum-adapted:ORDER:ELEMENTS:RATIO" or
/// "continuum-loop:ORDER:ELEMENTS" (the text parse_method reads).
std::string method_spec(const Method& method);
/// method_spec with " mirror" appended for Symmetry::mirror (messages and verdicts).
std::string method_spec(const Method& method, Symmetry symmetry);

}  // namespace rbc
