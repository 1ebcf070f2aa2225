// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Shared fixture of the discrete tests: a small (N ~ 250) perturbed cell network carrying
// a force and non-zero constraint multipliers, so that no energy term or derivative
// vanishes by symmetry.
#include "core/rest_shape.hpp"
#include "discrete/network.hpp"
#include "fixtures.hpp"

namespace rbc::testing {

struct SmallCell {
  Network net;
  Positions x;
  LoadState load;
  explicit SmallCell(NetworkParameters p = {}, unsigned seed = 11, double stiffness_scale = 1.0) {
    RestShapeOptions o;
    o.target_vertices = 250;
    net = build_network(make_rest_shape(o), p);
    x = net.rest;
    perturb(x, 0.02, seed);
    load.force_pN = 50.0;
    load.multipliers = {3.0, -1.5};
    load.stiffness_scale = stiffness_scale;
  }
};

}  // namespace rbc::testing
