// SPDX-License-Identifier: GPL-3.0-or-later
// Fuzz target: the CLI's number and force lists (app/cli_util.cpp, parse_number_list and
// parse_force_list). The only allowed failure is std::invalid_argument; an accepted list must
// keep the documented contract: one finite value per comma-separated item (>= 0 for forces).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/cli_util.hpp"

namespace {

void check(const std::string& text, const std::vector<double>& values, bool allow_negative) {
  std::size_t items = 1;
  for (char c : text) items += c == ',';
  if (values.size() != items) __builtin_trap();
  for (double v : values)
    if (!std::isfinite(v) || (!allow_negative && v < 0)) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    check(text, rbc::app::parse_force_list(text), false);
  } catch (const std::invalid_argument&) {
  }
  try {
    check(text, rbc::app::parse_number_list(text, "H0", "0,0.1 in 1/um", true), true);
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
