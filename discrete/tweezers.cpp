#include "discrete/tweezers.hpp"

#include <algorithm>
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
  for (int side = 0; side < 2; ++side) {  // side 0: largest x (+x pull); side 1: smallest x
    std::vector<int> chosen;
    double area = 0;
    const int target_count =
        std::max(1, static_cast<int>(std::lround(params.contact_fraction * n)));
    for (int k = 0; k < n; ++k) {
      const int v = side == 0 ? order[k] : order[n - 1 - k];
      if (params.rule == PatchRule::by_area) {
        // Take the vertex if that brings the patch area closer to the target.
        const double target = params.contact_fraction * total;
        if (std::abs(area + a(v) - target) > std::abs(area - target) && !chosen.empty()) break;
      } else if (static_cast<int>(chosen.size()) >= target_count) {
        break;
      }
      chosen.push_back(v);
      area += a(v);
    }
    const double sign = side == 0 ? 1.0 : -1.0;
    for (int v : chosen) {
      patch.vertex.push_back(v);
      patch.share.push_back(sign * (params.rule == PatchRule::by_area
                                        ? a(v) / area
                                        : 1.0 / static_cast<double>(chosen.size())));
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
