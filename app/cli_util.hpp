#pragma once
// Small helpers shared by the sub-commands: list parsing, progress to stderr, JSON output.
#include <iostream>
#include <string>
#include <vector>

#include "core/progress.hpp"

namespace rbc::app {

/// Parses "0,16,38.5" into forces in pN; throws std::invalid_argument naming the bad item
/// for non-numbers, negative or non-finite values.
std::vector<double> parse_force_list(const std::string& text);

/// Progress sink writing "[elapsed s] message" lines to stderr (quiet = discard).
ProgressSink stderr_progress(bool quiet);

}  // namespace rbc::app
