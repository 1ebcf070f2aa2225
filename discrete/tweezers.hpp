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
  void validate() const;  ///< contact_fraction finite in (0, 0.5) (rbc::InvalidParameter)
};

/// Bound vertices and their signed shares of the total force F along +x:
/// +a_i/A_patch at the +x bead, -a_i/A_patch at the -x bead (each side sums to +-1).
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
