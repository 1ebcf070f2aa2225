// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/tweezers.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "core/geometry.hpp"
#include "core/validation.hpp"

namespace rbc {

std::string to_string(PatchRule r) {
  return r == PatchRule::by_area ? "area" : "vertices";
}

PatchRule patch_rule_from_string(const std::string& name) {
  if (name == "area") return PatchRule::by_area;
  if (name == "vertices") return PatchRule::by_vertex_count;
  throw std::invalid_argument("contact rule '" + name + "' is not one of area, vertices");
}

void TweezersParameters::validate() const {
  require_finite_in_range("bead contact fraction", "", contact_fraction, 0.0, 0.5, Ends::open_open);
}

TweezerPatch select_tweezer_patch(const Positions& rest, const Topology& topo,
                                  const TweezersParameters& params) {
  params.validate();
  const Eigen::VectorXd a = vertex_areas(rest, topo);
  const double total = a.sum();
  const int n = topo.num_vertices;
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int i, int j) { return rest(0, i) > rest(0, j); });
  TweezerPatch patch;
  const int target_count = std::max(1, static_cast<int>(std::lround(params.contact_fraction * n)));
  const double target_area = params.contact_fraction * total;
  const bool by_area = params.rule == PatchRule::by_area;
  for (int side = 0; side < 2; ++side) {  // side 0: largest x (+x pull); side 1: smallest x
    auto vertex_at = [&](int k) { return side == 0 ? order[k] : order[n - 1 - k]; };
    std::vector<int> chosen;
    std::vector<double> weight;  // of each chosen vertex: 1, or the boundary level's fraction
    double area = 0;             // of the chosen vertices, times their weights
    for (int k = 0; k < n;) {
      // The next vertex, or with keep_equal_x_together every vertex at its rest x (a level).
      int end = k + 1;
      if (params.keep_equal_x_together)
        while (end < n &&
               std::abs(rest(0, vertex_at(end)) - rest(0, vertex_at(k))) <= kMirrorToleranceUm)
          ++end;
      double group_area = 0;
      for (int j = k; j < end; ++j) group_area += a(vertex_at(j));
      const double have = by_area ? area : static_cast<double>(chosen.size());
      const double group = by_area ? group_area : static_cast<double>(end - k);
      const double target = by_area ? target_area : static_cast<double>(target_count);
      double w = 1.0;
      if (params.keep_equal_x_together) {
        // Whole levels up to the target, then the next level at the fraction that meets it
        // (and no further: its rounding may leave `have` a last bit short of the target).
        if (have >= target * (1.0 - 1e-12)) break;
        w = std::min(1.0, (target - have) / group);
      } else if (std::abs(have + group - target) > std::abs(have - target) && !chosen.empty()) {
        break;  // a vertex is taken if that brings the patch closer to its target
      }
      for (int j = k; j < end; ++j) {
        chosen.push_back(vertex_at(j));
        weight.push_back(w);
        area += w * a(vertex_at(j));
      }
      k = end;
      if (w < 1.0) break;  // the edge level
    }
    double count = 0;
    for (double w : weight) count += w;
    const double sign = side == 0 ? 1.0 : -1.0;
    for (size_t c = 0; c < chosen.size(); ++c) {
      patch.vertex.push_back(chosen[c]);
      patch.share.push_back(sign * weight[c] * (by_area ? a(chosen[c]) / area : 1.0 / count));
    }
    (side == 0 ? patch.area_plus_um2 : patch.area_minus_um2) = area;
  }
  return patch;
}

MeshSymmetry tweezers_scene_symmetry(const Positions& rest, const Topology& topo,
                                     const TweezerPatch& patch) {
  return keep_invariant(find_mirror_symmetry(rest, topo), patch.vertex, patch.share, 0,
                        kTweezersShareTolerance);
}

double tweezers_energy(const TweezerPatch& patch, double force_pN, const Positions& x,
                       const Positions& rest, Positions* grad) {
  double e = 0.0;
  for (size_t k = 0; k < patch.vertex.size(); ++k) {
    const int v = patch.vertex[k];
    e -= force_pN * patch.share[k] * (x(0, v) - rest(0, v));
    if (grad) (*grad)(0, v) -= force_pN * patch.share[k];
  }
  return e;
}

}  // namespace rbc
