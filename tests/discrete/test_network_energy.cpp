// SPDX-License-Identifier: GPL-3.0-or-later
// The shared-geometry evaluation path (discrete/network_energy.hpp): one geometry
// pass and one chain-rule assembly for the whole production list. Its oracle is the
// term-by-term sum of the same list (each term's own kernel, finite-difference tested in
// test_term_derivatives.cpp): the two agree to round-off in the energy, every part and every
// gradient entry, on randomly perturbed meshes of one chunk and of several chunks, and both
// say +infinity for the same infeasible states.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/geometry.hpp"
#include "core/parallel.hpp"
#include "core/rest_shape.hpp"
#include "discrete/network.hpp"
#include "discrete/network_energy.hpp"
#include "discrete_cell_fixture.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

/// The production list without its shared-geometry hooks: sum_network_terms then calls each
/// term's own kernel.
std::vector<NetworkTerm> term_by_term(const Network& net) {
  std::vector<NetworkTerm> terms = network_terms(net);
  for (NetworkTerm& t : terms) {
    EXPECT_TRUE(bool(t.from_geometry)) << t.name;
    t.from_geometry = nullptr;
  }
  return terms;
}

void expect_paths_agree(const Network& net, const Positions& x, const LoadState& load) {
  Positions g1, g2;
  EnergyBreakdown p1, p2;
  const double e1 = network_energy(net, x, load, &g1, &p1);
  const double e2 = sum_network_terms(term_by_term(net), net, x, load, &g2, &p2);
  ASSERT_TRUE(std::isfinite(e1) && std::isfinite(e2));
  const double scale = std::abs(p2.links) + std::abs(p2.steric) + std::abs(p2.bending) +
                       std::abs(p2.constraints) + std::abs(p2.tweezers);
  EXPECT_NEAR(e1, e2, 1e-12 * scale);
  EXPECT_NEAR(p1.links, p2.links, 1e-12 * std::abs(p2.links));
  EXPECT_NEAR(p1.steric, p2.steric, 1e-12 * std::abs(p2.steric));
  EXPECT_NEAR(p1.bending, p2.bending, 1e-11 * std::abs(p2.bending));
  EXPECT_NEAR(p1.constraints, p2.constraints, 1e-12 * scale);
  EXPECT_EQ(p1.tweezers, p2.tweezers);
  const double gmax = g2.cwiseAbs().maxCoeff();
  EXPECT_GT(gmax, 0.0);
  EXPECT_LT((g1 - g2).cwiseAbs().maxCoeff(), 1e-10 * gmax);
  // Without a gradient the same energy.
  EXPECT_EQ(network_energy(net, x, load), e1);
}

TEST(SharedGeometry, AgreesWithTheTermByTermSumOnOneChunk) {
  for (unsigned seed : {11u, 12u}) {
    testing::SmallCell c({}, seed, 3.0);
    ASSERT_EQ(assembly_chunks(c.net.topo.num_edges()), 1);
    expect_paths_agree(c.net, c.x, c.load);
  }
}

TEST(SharedGeometry, AgreesWithTheTermByTermSumOnSeveralChunks) {
  RestShapeOptions o;
  o.target_vertices = 3000;
  const Network net = build_network(make_rest_shape(o), NetworkParameters{});
  ASSERT_GT(assembly_chunks(net.topo.num_edges()), 1);
  ASSERT_GT(assembly_chunks(net.topo.num_faces()), 1);
  Positions x = net.rest;
  testing::perturb(x, 0.02, 5);
  LoadState load;
  load.force_pN = 120.0;
  load.multipliers = {-2.0, 4.0};
  load.stiffness_scale = 0.5;
  expect_paths_agree(net, x, load);
}

TEST(SharedGeometry, HingeAnglesAreasAndTotalsAreThoseOfTheGeometryKernels) {
  testing::SmallCell c;
  const Topology& t = c.net.topo;
  const NetworkGeometry geo = network_geometry(c.x, t);
  double largest_angle = 0;
  for (int e = 0; e < t.num_edges(); ++e) {
    const double theta =
        dihedral_angle(c.x.col(t.edges(0, e)), c.x.col(t.edges(1, e)),
                       c.x.col(t.edge_opposite(0, e)), c.x.col(t.edge_opposite(1, e)));
    EXPECT_NEAR(geo.hinge_angle[e], theta, 1e-13);
    EXPECT_NEAR(geo.edge_length[e], edge_length(c.x.col(t.edges(0, e)), c.x.col(t.edges(1, e))),
                1e-15);
    largest_angle = std::max(largest_angle, std::abs(theta));
  }
  EXPECT_GT(largest_angle, 0.1);  // a perturbed cell: the angles are not all alike
  EXPECT_EQ(geo.area_um2, total_area(c.x, t));
  EXPECT_EQ(geo.volume_um3, enclosed_volume(c.x, t));
}

TEST(SharedGeometry, HingeAnglesOfEveryRangeAndSignAreThoseOfAtan2) {
  // The hinge angles' own atan2 (branch-free Cephes, three argument ranges, four quadrants)
  // against core/geometry.hpp's dihedral_angle (std::atan2) on a crumpled cell, whose angles
  // cover |theta| < 33.4 deg, the middle range, > 67.5 deg and > 90 deg (a negative cosine),
  // of both signs.
  testing::SmallCell c;
  const Topology& t = c.net.topo;
  Positions x = c.x;
  testing::perturb(x, 0.35, 3);
  const NetworkGeometry geo = network_geometry(x, t);
  constexpr double kPi = 3.14159265358979323846;
  int shallow = 0, middle = 0, steep = 0, obtuse = 0, negative = 0;
  for (int e = 0; e < t.num_edges(); ++e) {
    const double theta = dihedral_angle(x.col(t.edges(0, e)), x.col(t.edges(1, e)),
                                        x.col(t.edge_opposite(0, e)), x.col(t.edge_opposite(1, e)));
    EXPECT_NEAR(geo.hinge_angle[e], theta, 1e-13) << e;
    const double a = std::abs(theta);
    shallow += a<0.58, middle += a> 0.59 && a<1.17, steep += a> 1.18;
    obtuse += a > 0.5 * kPi, negative += theta < 0;
  }
  EXPECT_GT(shallow, 0);
  EXPECT_GT(middle, 0);
  EXPECT_GT(steep, 0);
  EXPECT_GT(obtuse, 0);
  EXPECT_GT(negative, 0);
  EXPECT_LT(negative, t.num_edges());
}

TEST(SharedGeometry, InfeasibleStatesAreInfiniteOnBothPaths) {
  testing::SmallCell c;
  const double inf = std::numeric_limits<double>::infinity();
  const Topology& t = c.net.topo;
  ASSERT_LT(c.net.lbar_um.maxCoeff() / c.net.wlc.x0, 9.0);
  // The energy loops work in blocks of 128 links or faces: the infeasible element at the start,
  // inside and at the end of the lists (the last face and the last vertex's links).
  ASSERT_GT(t.num_faces(), 3 * 128);
  for (const int k : {0, t.num_faces() / 2 + 7, t.num_faces() - 1}) {
    // A link past Lmax: move one vertex 10 um out (Lmax = Lbar/x0 ~ 3 Lbar < 10 um here).
    const int v = std::min(k, t.num_vertices - 1);
    Positions far = c.x;
    far.col(v) += Eigen::Vector3d(10.0, 0.0, 0.0);
    // A collapsed face: one vertex onto the midpoint of its opposite edge in face k.
    Positions flat = c.x;
    const auto f = t.faces.col(k);
    flat.col(f(0)) = 0.5 * (flat.col(f(1)) + flat.col(f(2)));
    for (const Positions* x : {&far, &flat}) {
      Positions g;
      EXPECT_EQ(network_energy(c.net, *x, c.load, &g), inf) << k;
      EXPECT_EQ(sum_network_terms(term_by_term(c.net), c.net, *x, c.load, &g, nullptr), inf) << k;
    }
  }
}

}  // namespace
}  // namespace rbc
