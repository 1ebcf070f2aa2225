// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Optical-tweezers load (MODEL.md section 2, "Optical tweezers"; Mills et al. 2004).
#include <string>
#include <vector>

#include "core/mesh.hpp"
#include "core/mirror_symmetry.hpp"

namespace rbc {

/// Which vertices the beads hold.
enum class PatchRule {
  /// The part of the rest surface with the largest (smallest) x whose area is
  /// contact_fraction of the total; force shared by vertex area (default).
  by_area,
  /// Li et al. 2005: contact_fraction of the vertices at each end, equal shares.
  by_vertex_count,
};
std::string to_string(PatchRule r);
PatchRule patch_rule_from_string(const std::string& name);

struct TweezersParameters {
  double contact_fraction = 0.05;  ///< of the surface area (or vertices) at each bead
  PatchRule rule = PatchRule::by_area;
  /// Treat the vertices at the same rest x (to kMirrorToleranceUm) as one level: whole levels
  /// from the bead's end up to the target, then the next level with every share scaled by the
  /// fraction that meets the target exactly (area or count). The patch is then a cap x >= x_c
  /// with a smeared edge; it keeps the mesh's y -> -y and z -> -z mirrors, and its area is the
  /// target (snapping whole levels left it 3-12 % short on the mirror-planes meshes, which moved
  /// the network's D_A by +0.5 % at N = 1,962). Off by default: the default meshes' patches are
  /// cut vertex by vertex, whichever brings them closer to the target, as they always were (a
  /// cut through a mirror pair breaks that mirror: tweezers_scene_symmetry). On with the
  /// mirror-planes triangulation (core/rest_shape.hpp TriangulationOrientation), whose scene
  /// then keeps all eight mirror elements.
  bool keep_equal_x_together = false;
  void validate() const;  ///< contact_fraction finite in (0, 0.5) (rbc::InvalidParameter)
};

/// Bound vertices and their signed shares of the total force F along +x:
/// +w_i a_i/A_patch at the +x bead, -w_i a_i/A_patch at the -x bead (each side sums to +-1),
/// with w_i = 1 except on a level patch's edge level (keep_equal_x_together); A_patch =
/// sum w_i a_i (area_plus_um2, area_minus_um2).
struct TweezerPatch {
  std::vector<int> vertex;
  std::vector<double> share;
  double area_plus_um2 = 0, area_minus_um2 = 0;
};

TweezerPatch select_tweezer_patch(const Positions& rest, const Topology& topo,
                                  const TweezersParameters& params);

/// The mirror symmetries of the stretch scene on a rest mesh (core/mirror_symmetry.hpp): the
/// reflections that map the rest mesh onto itself (find_mirror_symmetry) and keep the bead
/// load, i.e. map each bead's shares onto the same or, for x -> -x, the other bead's (the
/// signed share changes sign with x). The patch rule snaps to whole vertices, so a mirror pair
/// split by the patch's edge breaks that mirror (e.g. the default meshes of N = 500 and 8,000
/// keep 2 of their 4 reflections).
/// Shares are area fractions of order 1/(patch vertices): differences below this are round-off.
inline constexpr double kTweezersShareTolerance = 1e-12;
MeshSymmetry tweezers_scene_symmetry(const Positions& rest, const Topology& topo,
                                     const TweezerPatch& patch);

/// Work potential of the beads: E = -F sum_i share_i e_x . (x_i - X_i)  [pN um];
/// gradient dE/dx_i = -F share_i e_x accumulated into grad.
double tweezers_energy(const TweezerPatch& patch, double force_pN, const Positions& x,
                       const Positions& rest, Positions* grad = nullptr);

}  // namespace rbc
