// SPDX-License-Identifier: GPL-3.0-or-later
// Fuzz target: the calibration's prior and parameter-list strings (calibrate/prior_spec.cpp,
// `rbc infer --prior persistence=3:20 --params persistence,lmax`). The only allowed failure is
// std::invalid_argument; an accepted prior must be a finite, non-empty, physical box (the
// contract of PriorRange::validate), and an accepted list has no repeated parameter.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "calibrate/prior_spec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const rbc::PriorRange r = rbc::parse_prior(text);
    if (!std::isfinite(r.lower) || !std::isfinite(r.upper) || !(r.lower < r.upper))
      __builtin_trap();
    r.validate();  // must not throw for an accepted box
  } catch (const std::invalid_argument&) {
  }
  try {
    const std::vector<rbc::Parameter> list = rbc::parse_parameter_list(text);
    if (list.empty()) __builtin_trap();
    for (std::size_t i = 0; i < list.size(); ++i)
      for (std::size_t j = i + 1; j < list.size(); ++j)
        if (list[i] == list[j]) __builtin_trap();
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
