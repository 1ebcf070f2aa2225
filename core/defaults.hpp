// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The physical defaults of the model, defined once, in the natural units a user states them
// in (nm, J, K): Li et al. 2005 / Table 1 of the paper for the spectrin WLC, Table 2 for the
// bilayer bending rigidity. The library's internal-unit defaults (WlcParameters,
// BendingParameters) are these converted by core/units.hpp, and the front ends (CLI, Python)
// use the same constants, so every path gives the same bits (2e-19 J -> 0.19999999999999998
// pN um and 237.75 nm -> 0.23775000000000002 um, not the literals 0.2 and 0.23775).
namespace rbc::defaults {

inline constexpr double kLbar_nm = 75.0;            ///< spectrin rest link length Lbar
inline constexpr double kLmax_nm = 237.75;          ///< spectrin contour length Lmax
inline constexpr double kPersistence_nm = 7.5;      ///< spectrin persistence length p
inline constexpr double kWlcTemperature_K = 300.0;  ///< temperature of the WLC links
inline constexpr double kKappa_J = 2e-19;           ///< bilayer bending rigidity kappa

}  // namespace rbc::defaults
