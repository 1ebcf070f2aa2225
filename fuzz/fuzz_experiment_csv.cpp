// SPDX-License-Identifier: GPL-3.0-or-later
// Fuzz target: the CSV reader (core/csv.cpp, parse_csv) and the Mills data file on top of it
// (compare/experiment.cpp, parse_experiment). The only allowed failure is std::runtime_error; an
// accepted table must keep the documented contract: every row as wide as the header, and an
// accepted experiment finite, forces >= 0 and increasing, diameters and error bars > 0. A
// refusal's message is one line of printable ASCII: text quoted from the file has its other
// bytes escaped, so a NUL in the file cannot cut the message short.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

#include "compare/experiment.hpp"
#include "core/io.hpp"

namespace {
void check_message(const std::runtime_error& e) {
  for (const char* c = e.what(); *c; ++c)
    if (static_cast<unsigned char>(*c) < 0x20 || static_cast<unsigned char>(*c) > 0x7e)
      __builtin_trap();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    std::istringstream in(text);
    const rbc::CsvTable t = rbc::parse_csv(in, "fuzz.csv");
    if (t.header.empty()) __builtin_trap();
    for (const auto& row : t.rows)
      if (row.size() != t.header.size()) __builtin_trap();
  } catch (const std::runtime_error& e) {
    check_message(e);
  }
  try {
    std::istringstream in(text);
    const auto points = rbc::parse_experiment(in, "fuzz.csv");
    if (points.empty()) __builtin_trap();
    double previous = -1;
    for (const auto& p : points) {
      const double v[] = {p.force_pN, p.axial_um, p.axial_err_um, p.transverse_um,
                          p.transverse_err_um};
      for (double x : v)
        if (!std::isfinite(x)) __builtin_trap();
      if (!(p.force_pN >= 0 && p.force_pN > previous)) __builtin_trap();
      if (!(p.axial_um > 0 && p.transverse_um > 0 && p.axial_err_um > 0 && p.transverse_err_um > 0))
        __builtin_trap();
      previous = p.force_pN;
    }
  } catch (const std::runtime_error& e) {
    check_message(e);
  }
  return 0;
}
