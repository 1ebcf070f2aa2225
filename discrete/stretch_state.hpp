// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The state a stretch leaves behind and a warm re-solve starts from: one equilibrium
// (positions and the area/volume multipliers) per force. Shared by the discrete
// (discrete/stretch.hpp) and continuum (continuum/continuum_stretch.hpp) drivers, so a
// calibration can re-solve the same scene after a small parameter change from the
// previous sample's equilibria instead of continuing from the rest shape.
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/mesh.hpp"
#include "discrete/constraint_energy.hpp"

namespace rbc {

struct StretchState {
  std::vector<double> forces_pN;                   ///< bead force of each equilibrium (pN)
  std::vector<Positions> x;                        ///< 3 x N equilibrium positions (um)
  std::vector<ConstraintMultipliers> multipliers;  ///< lambda_A (pN/um), lambda_V (pN/um^2)
  bool empty() const { return forces_pN.empty(); }

  /// Throws std::invalid_argument unless the state holds one finite 3 x `vertices`
  /// equilibrium for each of `forces_pN` (same forces, same order).
  void check_matches(int vertices, const std::vector<double>& forces) const {
    if (x.size() != forces_pN.size() || multipliers.size() != forces_pN.size())
      throw std::invalid_argument(
          "warm-start state is inconsistent: " + std::to_string(forces_pN.size()) + " forces, " +
          std::to_string(x.size()) + " shapes, " + std::to_string(multipliers.size()) +
          " multiplier pairs");
    if (forces_pN != forces)
      throw std::invalid_argument("warm-start state holds " + std::to_string(forces_pN.size()) +
                                  " forces that differ from the " + std::to_string(forces.size()) +
                                  " requested; expected the same forces in the same order");
    for (size_t k = 0; k < x.size(); ++k) {
      if (x[k].rows() != 3 || x[k].cols() != vertices)
        throw std::invalid_argument("warm-start shape " + std::to_string(k) + " has " +
                                    std::to_string(x[k].cols()) + " vertices, expected " +
                                    std::to_string(vertices) + " (the same mesh)");
      if (!x[k].allFinite() || !std::isfinite(multipliers[k].area_pN_per_um) ||
          !std::isfinite(multipliers[k].volume_pN_per_um2))
        throw std::invalid_argument("warm-start state " + std::to_string(k) +
                                    " holds non-finite positions or multipliers");
    }
  }
};

/// What a sweep solver's kept state (ContinuumSweepSolver, StretchSweepSolver) is valid for:
/// one force list on one mesh (vertex count and faces).
struct SweepScene {
  std::vector<double> forces_pN;
  int vertices = -1;
  Faces faces;
  /// Whether forces and topo differ from this scene; if so, this becomes theirs.
  bool change_to(const std::vector<double>& forces, const Topology& topo) {
    const bool same = forces == forces_pN && topo.num_vertices == vertices &&
                      topo.faces.cols() == faces.cols() &&
                      (topo.faces.array() == faces.array()).all();
    if (same) return false;
    forces_pN = forces;
    vertices = topo.num_vertices;
    faces = topo.faces;
    return true;
  }
};

/// The state of a run's points (any point type with force_pN, x and multipliers: the discrete
/// StretchPoint, the continuum ContinuumStretchPoint).
template <class Points>
StretchState stretch_state_of(const Points& points) {
  StretchState s;
  for (const auto& p : points) {
    s.forces_pN.push_back(p.force_pN);
    s.x.push_back(p.x);
    s.multipliers.push_back(p.multipliers);
  }
  return s;
}

}  // namespace rbc
