#pragma once
// Small helpers shared by the sub-commands: list parsing, progress to stderr, JSON output.
#include <iostream>
#include <string>
#include <vector>

#include "core/progress.hpp"

namespace rbc::app {

/// Parses a comma-separated list of finite numbers; throws std::invalid_argument naming the
/// bad item and `what` (e.g. "force"), with `example` as the expected form. Negative values
/// are refused unless allow_negative.
std::vector<double> parse_number_list(const std::string& text, const std::string& what,
                                      const std::string& example, bool allow_negative);

/// Parses "0,16,38.5" into forces in pN (finite, >= 0).
std::vector<double> parse_force_list(const std::string& text);

/// Progress sink writing "[elapsed s] message" lines to stderr (quiet = discard).
ProgressSink stderr_progress(bool quiet);

}  // namespace rbc::app
