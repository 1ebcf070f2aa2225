// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Parameter sets spanning the admissible range (units um, K), shared by the homogenise tests.
#include <utility>
#include <vector>

#include "discrete/steric_energy.hpp"
#include "discrete/wlc.hpp"

namespace rbc::testing {

inline std::vector<std::pair<WlcParameters, StericParameters>> parameter_sets() {
  return {{WlcParameters{}, StericParameters{}},
          {WlcParameters{}, StericParameters{2.0, 0.005}},
          {WlcParameters{0.05, 0.1, 0.01, 310.0}, StericParameters{0.5, 0.1}},
          {WlcParameters{0.1, 0.5, 0.004, 280.0}, StericParameters{3.0, 0.02}},
          {WlcParameters{0.075, 0.09, 0.0075, 300.0}, StericParameters{1.0, 0.5}}};
}

}  // namespace rbc::testing
