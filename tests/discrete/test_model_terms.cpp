// SPDX-License-Identifier: GPL-3.0-or-later
// "Adding a bending law touches one unit": a network model is the list of its terms
// (discrete/network.hpp NetworkTerm); the production models are network_terms(net), and a test
// builds its own model from a list that swaps in a test-only bending law, through the same
// interface, and stretches it with the production driver (run_stretch, Newton-preconditioned:
// the law's Hessian blocks enter NetworkHessian through its LocalPieces) and samples it with
// the Monte Carlo sampler (its local energy changes through the same pieces).
#include <gtest/gtest.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <random>

#include "discrete/mc_sampler.hpp"
#include "discrete/network.hpp"
#include "discrete/network_hessian.hpp"
#include "discrete/stretch.hpp"
#include "discrete_cell_fixture.hpp"
#include "fd_order.hpp"

namespace rbc {
namespace {

using testing::SmallCell;

/// Test-only bending law, the quartic umbrella E = (k/4) sum_v |d_v|^4 with the umbrella vector
/// d_v = x_v - (1/deg v) sum_{w in N(v)} x_w (um): zero on any uniform planar 1-ring, growing
/// with the local curvature. k in pN/um^3, E in pN um. dE/dd_v = G_v = k |d_v|^2 d_v, so
/// dE/dx_u = G_u - sum_{v: u in N(v)} G_v / deg v.
double quartic_umbrella(const Topology& t, double k, const Positions& x, Positions* grad) {
  const int n = t.num_vertices;
  Positions d(3, n);
  for (int v = 0; v < n; ++v) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    const int deg = static_cast<int>(t.vertex_neighbours.end(v) - t.vertex_neighbours.begin(v));
    for (const int* w = t.vertex_neighbours.begin(v); w != t.vertex_neighbours.end(v); ++w)
      mean += x.col(*w);
    d.col(v) = x.col(v) - mean / deg;
  }
  double e = 0;
  for (int v = 0; v < n; ++v) e += 0.25 * k * d.col(v).squaredNorm() * d.col(v).squaredNorm();
  if (grad)
    for (int v = 0; v < n; ++v) {
      const Eigen::Vector3d g = k * d.col(v).squaredNorm() * d.col(v);
      const int deg = static_cast<int>(t.vertex_neighbours.end(v) - t.vertex_neighbours.begin(v));
      grad->col(v) += g;
      for (const int* w = t.vertex_neighbours.begin(v); w != t.vertex_neighbours.end(v); ++w)
        grad->col(*w) -= g / deg;
    }
  return e;
}

constexpr double kUmbrella_pN_per_um3 = 2.0e3;

/// The law's pieces: piece v is the star (v, its neighbours in vertex_neighbours order), with
///   e_v = (k/4) |d_v|^4,  d2e_v/dx_a dx_b = c_a c_b k (|d_v|^2 I + 2 d_v d_v^T),
/// c_v = 1 and c_w = -1/deg v for the neighbours (d_v is linear in the star's positions).
PieceLayout umbrella_layout(const Topology& t) {
  PieceLayout l;
  for (int v = 0; v < t.num_vertices; ++v) {
    l.vertices.push_back(v);
    l.vertices.insert(l.vertices.end(), t.vertex_neighbours.begin(v), t.vertex_neighbours.end(v));
    l.offsets.push_back(static_cast<int>(l.vertices.size()));
  }
  return l;
}
Eigen::Vector3d umbrella_vector(const Topology& t, const Positions& x, int v) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  const int deg = static_cast<int>(t.vertex_neighbours.end(v) - t.vertex_neighbours.begin(v));
  for (const int* w = t.vertex_neighbours.begin(v); w != t.vertex_neighbours.end(v); ++w)
    mean += x.col(*w);
  return x.col(v) - mean / deg;
}
double umbrella_piece_energy(const Network& n, const Positions& x, int v) {
  const double d2 = umbrella_vector(n.topo, x, v).squaredNorm();
  return 0.25 * kUmbrella_pN_per_um3 * d2 * d2;
}
Eigen::MatrixXd umbrella_piece_hessian(const Network& n, const Positions& x, int v) {
  const Topology& t = n.topo;
  const int deg = static_cast<int>(t.vertex_neighbours.end(v) - t.vertex_neighbours.begin(v));
  const Eigen::Vector3d d = umbrella_vector(t, x, v);
  const Eigen::Matrix3d a = kUmbrella_pN_per_um3 *
                            (d.squaredNorm() * Eigen::Matrix3d::Identity() + 2 * d * d.transpose());
  Eigen::MatrixXd h(3 * (deg + 1), 3 * (deg + 1));
  for (int i = 0; i <= deg; ++i)
    for (int j = 0; j <= deg; ++j)
      h.block<3, 3>(3 * i, 3 * j) = (i ? -1.0 / deg : 1.0) * (j ? -1.0 / deg : 1.0) * a;
  return h;
}

/// The production list with its bending term replaced by the quartic umbrella: the one unit a
/// new law adds (its energy and gradient, and its pieces for the preconditioner and sampler).
std::vector<NetworkTerm> umbrella_model_terms(const Network& net) {
  std::vector<NetworkTerm> terms = network_terms(net);
  for (NetworkTerm& t : terms)
    if (t.name.rfind("bending", 0) == 0)
      t = {"bending (test-only quartic umbrella)",
           [](const Network& n, const Positions& x, const LoadState&, Positions* grad,
              EnergyBreakdown& e) {
             return e.bending = quartic_umbrella(n.topo, kUmbrella_pN_per_um3, x, grad);
           },
           {},  // no shared-geometry path: the sum takes the term-by-term path
           TermKind::custom,
           {[](const Network& n) { return umbrella_layout(n.topo); }, umbrella_piece_energy,
            umbrella_piece_hessian}};
  return terms;
}

/// The production list without a bending term.
std::vector<NetworkTerm> no_bending_terms(const Network& net) {
  std::vector<NetworkTerm> terms;
  for (const NetworkTerm& t : network_terms(net))
    if (t.name.rfind("bending", 0) != 0) terms.push_back(t);
  return terms;
}

/// Dense symmetric matrix of the pieces' Hessians.
Eigen::MatrixXd dense_piece_hessian(const Network& n, const Positions& x) {
  const PieceLayout l = umbrella_layout(n.topo);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(3 * x.cols(), 3 * x.cols());
  for (int p = 0; p < l.count(); ++p) {
    const Eigen::MatrixXd hp = umbrella_piece_hessian(n, x, p);
    const int k0 = l.offsets[p], size = l.offsets[p + 1] - k0;
    for (int i = 0; i < size; ++i)
      for (int j = 0; j < size; ++j)
        h.block<3, 3>(3 * l.vertices[k0 + i], 3 * l.vertices[k0 + j]) +=
            hp.block<3, 3>(3 * i, 3 * j);
  }
  return h;
}

TEST(ModelTerms, TheProductionListIsNetworkEnergy) {
  SmallCell c;
  const std::vector<NetworkTerm> terms = network_terms(c.net);
  ASSERT_EQ(terms.size(), 4u);
  EXPECT_EQ(terms[1].name, "bending (juelicher)");
  Positions g1, g2;
  EnergyBreakdown p1, p2;
  const double e1 = network_energy(c.net, c.x, c.load, &g1, &p1);
  const double e2 = sum_network_terms(terms, c.net, c.x, c.load, &g2, &p2);
  EXPECT_EQ(e1, e2);  // the same sum in the same order: bit for bit
  EXPECT_EQ((g1 - g2).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(p1.bending, p2.bending);
  EXPECT_EQ(p1.tweezers, p2.tweezers);
  EXPECT_NE(p1.bending, 0.0);
}

TEST(ModelTerms, TestOnlyLawHasASecondOrderGradient) {
  SmallCell c;
  const Topology& t = c.net.topo;
  const auto energy = [&](const Eigen::VectorXd& v) {
    return quartic_umbrella(t, kUmbrella_pN_per_um3,
                            Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, v.size() / 3), nullptr);
  };
  Positions g = Positions::Zero(3, c.x.cols());
  quartic_umbrella(t, kUmbrella_pN_per_um3, c.x, &g);
  for (unsigned seed : {1u, 2u})
    testing::expect_second_order(
        testing::gradient_order(energy, flat(c.x), flat(g), c.net.lbar_um.mean(), seed),
        "quartic umbrella gradient");
}

TEST(ModelTerms, TestOnlyLawPiecesSumToItsEnergyAndHaveItsSecondOrderHessian) {
  SmallCell c;
  const Topology& t = c.net.topo;
  double sum = 0;
  for (int v = 0; v < t.num_vertices; ++v) sum += umbrella_piece_energy(c.net, c.x, v);
  const double e = quartic_umbrella(t, kUmbrella_pN_per_um3, c.x, nullptr);
  EXPECT_NEAR(sum, e, 1e-12 * e);
  const Eigen::MatrixXd h = dense_piece_hessian(c.net, c.x);
  const auto grad = [&](const Eigen::VectorXd& v) {
    Positions g = Positions::Zero(3, c.x.cols());
    quartic_umbrella(t, kUmbrella_pN_per_um3,
                     Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, v.size() / 3), &g);
    return Eigen::VectorXd(flat(g));
  };
  for (unsigned seed : {3u, 4u})
    testing::expect_second_order(
        testing::hessian_order(
            grad, flat(c.x), [&](const Eigen::VectorXd& d) { return Eigen::VectorXd(h * d); },
            c.net.lbar_um.mean(), seed),
        "quartic umbrella piece Hessian");
}

TEST(ModelTerms, TheNetworkHessianAssemblesTheTermsOfTheList) {
  // Exact assembly (no projection, no shift): the umbrella model's matrix minus that of the
  // same list without a bending term is the law's own Hessian; with the production list the
  // Juelicher blocks are there instead.
  SmallCell c;
  NetworkHessianOptions o;
  o.project = false;
  o.shift_fraction = 0.0;
  ConstraintCurvature cc{0.7, -0.3};
  const auto dense = [&](const std::vector<NetworkTerm>& terms) {
    Network n = c.net;
    n.terms = terms;
    NetworkHessian h(n, o);
    return Eigen::MatrixXd(Eigen::MatrixXd(h.assemble(c.x, cc)).selfadjointView<Eigen::Lower>());
  };
  const Eigen::MatrixXd base = dense(no_bending_terms(c.net));
  const Eigen::MatrixXd umbrella = dense(umbrella_model_terms(c.net));
  const Eigen::MatrixXd law = dense_piece_hessian(c.net, c.x);
  EXPECT_LT((umbrella - base - law).cwiseAbs().maxCoeff(), 1e-10 * law.cwiseAbs().maxCoeff());
  const Eigen::MatrixXd production = dense(network_terms(c.net));
  EXPECT_GT((production - base).cwiseAbs().maxCoeff(), 1e-3 * base.cwiseAbs().maxCoeff());
  // A list without the in-plane term cannot be preconditioned.
  Network bare = c.net;
  bare.terms = {umbrella_model_terms(c.net)[1]};
  EXPECT_THROW(NetworkHessian(bare, o), std::invalid_argument);
}

TEST(ModelTerms, AModelBuiltFromItsOwnListIsStretchedByTheProductionDriver) {
  SmallCell c;
  StretchOptions so;
  so.minimiser.force_tolerance = 1e-4;
  const std::vector<double> forces = {0.0, 60.0};
  // The production list set explicitly is the default model, bit for bit.
  Network listed = c.net;
  listed.terms = network_terms(c.net);
  const auto a = run_stretch(c.net, forces, so);
  const auto b = run_stretch(listed, forces, so);
  ASSERT_TRUE(a[1].converged && b[1].converged) << to_string(a[1].status);
  EXPECT_EQ(a[1].axial_um, b[1].axial_um);
  EXPECT_EQ(a[1].transverse_um, b[1].transverse_um);
  // The test-only law in place of Juelicher: the driver minimises that sum.
  Network umbrella = c.net;
  umbrella.terms = umbrella_model_terms(c.net);
  const auto u = run_stretch(umbrella, forces, so);
  ASSERT_TRUE(u[0].converged && u[1].converged) << to_string(u[1].status);
  // At its equilibrium the listed sum is stationary (largest net vertex force below the
  // tolerance) and the production model is not (the law really changed) ...
  LoadState load;
  load.force_pN = 60.0;
  load.multipliers = u[1].multipliers;
  load.stiffness_scale = u[1].stiffness_scale;
  Positions gu, gp;
  sum_network_terms(umbrella.terms, umbrella, u[1].x, load, &gu, nullptr);
  network_energy(c.net, u[1].x, load, &gp);
  // (the multipliers were updated once more after the last minimisation only if it did not
  // hold the constraints; it did, so they are those of the last minimisation)
  EXPECT_LT(gu.colwise().norm().maxCoeff(), 10 * so.minimiser.force_tolerance);
  EXPECT_GT(gp.colwise().norm().maxCoeff(), 100 * so.minimiser.force_tolerance);
  // ... the cell still stretches along the force and narrows across it, with area and volume
  // held.
  EXPECT_GT(u[1].axial_um, u[0].axial_um + 0.05);
  EXPECT_LT(u[1].transverse_um, u[0].transverse_um);
  EXPECT_LT(std::abs(u[1].area_drift), c.net.constraints.tolerance);
  EXPECT_LT(std::abs(u[1].volume_drift), c.net.constraints.tolerance);
  EXPECT_NE(u[1].axial_um, a[1].axial_um);
  // It went through the Newton preconditioner, which now holds the law's blocks: plain L-BFGS
  // reaches the same equilibrium (to the tolerance's slack).
  EXPECT_GT(u[1].factorisations, 0);
  StretchOptions plain = so;
  plain.precondition_min_vertices = INT_MAX;
  const auto q = run_stretch(umbrella, forces, plain);
  ASSERT_TRUE(q[1].converged);
  EXPECT_EQ(q[1].factorisations, 0);
  EXPECT_NEAR(q[1].axial_um, u[1].axial_um, 1e-4 * u[1].axial_um);
  EXPECT_NEAR(q[1].transverse_um, u[1].transverse_um, 1e-4 * u[1].transverse_um);
}

TEST(ModelTerms, TheMonteCarloSamplerRunsTheTestOnlyLaw) {
  SmallCell c;
  Network umbrella = c.net;
  umbrella.terms = umbrella_model_terms(c.net);
  McOptions o;
  o.seed = 5;
  o.adapt_sweeps = 5;
  McSampler mc(umbrella, c.load, c.x, o);
  // Every local change equals the from-scratch difference of the listed sum (independent
  // truth: sum_network_terms over all vertices), for random moves of random vertices.
  std::mt19937 rng(8);
  std::uniform_int_distribution<int> pick(0, c.x.cols() - 1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double e0 = sum_network_terms(umbrella.terms, umbrella, c.x, c.load, nullptr, nullptr);
  double largest = 0;
  for (int k = 0; k < 30; ++k) {
    const int v = pick(rng);
    Positions y = c.x;
    for (int i = 0; i < 3; ++i) y(i, v) += 0.01 * u(rng);
    const double exact =
        sum_network_terms(umbrella.terms, umbrella, y, c.load, nullptr, nullptr) - e0;
    const double local = mc.move_energy_change(v, y.col(v));
    EXPECT_NEAR(local, exact, 1e-9 * std::abs(e0)) << "vertex " << v;
    largest = std::max(largest, std::abs(exact));
  }
  EXPECT_GT(largest, 1e-6);  // the moves change the energy
  // A run: the cached sum stays the listed sum, and it is a different chain from production.
  for (int s = 0; s < 20; ++s) mc.sweep();
  const double listed =
      sum_network_terms(umbrella.terms, umbrella, mc.positions(), c.load, nullptr, nullptr);
  EXPECT_NEAR(mc.energy(), listed, 1e-10 * std::abs(listed));
  McSampler prod(c.net, c.load, c.x, o);
  for (int s = 0; s < 20; ++s) prod.sweep();
  EXPECT_GT((prod.positions() - mc.positions()).cwiseAbs().maxCoeff(), 0.0);
  // The production list set explicitly is the default chain, bit for bit.
  Network listed_net = c.net;
  listed_net.terms = network_terms(c.net);
  McSampler same(listed_net, c.load, c.x, o);
  for (int s = 0; s < 20; ++s) same.sweep();
  EXPECT_EQ((same.positions() - prod.positions()).cwiseAbs().maxCoeff(), 0.0);
  // A custom term without local pieces is refused, and so is a piece spanning three edges.
  Network bare = c.net;
  bare.terms = umbrella_model_terms(c.net);
  bare.terms[1].pieces = {};
  EXPECT_THROW(McSampler(bare, c.load, c.x, o), std::invalid_argument);
  std::vector<int> dist(c.x.cols(), -1), queue = {0};
  dist[0] = 0;
  for (std::size_t i = 0; i < queue.size(); ++i)
    for (const int* w = c.net.topo.vertex_neighbours.begin(queue[i]);
         w != c.net.topo.vertex_neighbours.end(queue[i]); ++w)
      if (dist[*w] < 0) {
        dist[*w] = dist[queue[i]] + 1;
        queue.push_back(*w);
      }
  const int far = static_cast<int>(std::find(dist.begin(), dist.end(), 3) - dist.begin());
  ASSERT_LT(far, c.x.cols());
  PieceLayout wide;
  wide.vertices = {0, far};
  wide.offsets = {0, 2};
  EXPECT_THROW(piece_stencil(c.net.topo, wide), std::invalid_argument);
}

}  // namespace
}  // namespace rbc
