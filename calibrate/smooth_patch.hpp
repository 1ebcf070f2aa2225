// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Bead contact patches with fractional area weights, so the load is a continuous function
// of the contact fraction (discrete/tweezers.hpp's by_area rule snaps to whole vertices,
// which makes D_A(contact fraction) a staircase no sampler can use).
#include "core/mesh.hpp"
#include "discrete/tweezers.hpp"

namespace rbc {

/// At each end the vertices are taken in order of decreasing (increasing) rest x with their
/// vertex areas a_i (um^2) until the patch reaches fraction x total area A; the vertex that
/// crosses the target enters with the weight w in (0, 1] of its area that completes it:
///   w_i = clamp((fraction A - sum_{j before i} a_j)/a_i, 0, 1),  share_i = +- w_i a_i/(fraction
///   A).
/// Each side's shares sum to +-1 exactly; the patch area is fraction x A exactly; the shares
/// are continuous and piecewise linear in the fraction. fraction must be in (0, 0.5)
/// (throws std::invalid_argument naming it otherwise).
TweezerPatch smooth_tweezer_patch(const Positions& rest, const Topology& topo, double fraction);

}  // namespace rbc
