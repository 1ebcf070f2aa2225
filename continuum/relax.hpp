// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Rest-shape relaxation (paper Sec. 5.3.1, Fig. 5; Li et al. 2005): minimise the
// Canham-Helfrich energy at fixed total area and enclosed volume from the Evans-Fung
// shape, in-plane elasticity off, and report how far the shape moves.
#include "continuum/continuum_model.hpp"
#include "continuum/newton_solver.hpp"
#include "core/progress.hpp"

namespace rbc {

/// Shape measures of a disc-like cell with axis z (um).
struct DiscShape {
  double diameter_um = 0;          ///< mean of the x and y extents
  double thickness_centre_um = 0;  ///< z gap between the vertices nearest the axis, top and bottom
  double thickness_rim_um = 0;     ///< largest thickness, max z - min z (at the rim torus)
};
DiscShape measure_disc(const Positions& x);

struct RelaxResult {
  NewtonResult solve;
  Positions x;                                           ///< relaxed positions (um)
  double largest_displacement_um = 0;                    ///< max_i |x_i - X_i|
  double energy_before_pNum = 0, energy_after_pNum = 0;  ///< Helfrich energy
  double regulariser_energy_pNum = 0;                    ///< in-plane regulariser energy at the end
  DiscShape before, after;
  double wall_s = 0;
};

/// Relaxes the rest mesh under bending (kappa, H0) with area and volume held exactly.
///
/// The continuum Helfrich energy is invariant under tangential reparametrisation, and the
/// Juelicher operator nearly so: with in-plane elasticity strictly off, Newton's method
/// slides vertices tangentially until triangles degenerate (observed: the net force stops
/// decreasing at ~0.5 pN on 2,000 elements). `regulariser` (e.g. the membrane law scaled by
/// 1e-3, see scaled_law) holds the mesh together; at that scale it stores ~1e-3 of the
/// bending energy and moves the relaxed shape by far less than the relaxation itself
/// (reported by rbc relax). Pass an empty law for no regulariser.
RelaxResult relax_helfrich(const TriMesh& rest, const BendingParameters& bending,
                           const IsotropicMembraneLaw& regulariser, const NewtonOptions& options,
                           const ProgressSink& progress = {});

}  // namespace rbc
