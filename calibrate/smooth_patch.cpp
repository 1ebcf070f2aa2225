// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/smooth_patch.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "core/geometry.hpp"

namespace rbc {

TweezerPatch smooth_tweezer_patch(const Positions& rest, const Topology& topo, double fraction) {
  if (!(fraction > 0 && fraction < 0.5))
    throw std::invalid_argument("contact fraction must lie in (0, 0.5), got " +
                                std::to_string(fraction));
  const Eigen::VectorXd a = vertex_areas(rest, topo);
  const double target = fraction * a.sum();
  const int n = topo.num_vertices;
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  // Ties broken by index so the order (and the patch) is unique.
  std::sort(order.begin(), order.end(), [&](int i, int j) {
    return rest(0, i) > rest(0, j) || (rest(0, i) == rest(0, j) && i < j);
  });
  TweezerPatch patch;
  for (int side = 0; side < 2; ++side) {
    const double sign = side == 0 ? 1.0 : -1.0;
    double area = 0;
    for (int k = 0; k < n && area < target; ++k) {
      const int v = side == 0 ? order[k] : order[n - 1 - k];
      const double w = std::clamp((target - area) / a(v), 0.0, 1.0);
      patch.vertex.push_back(v);
      patch.share.push_back(sign * w * a(v) / target);
      area += w * a(v);
    }
    (side == 0 ? patch.area_plus_um2 : patch.area_minus_um2) = target;
  }
  return patch;
}

}  // namespace rbc
