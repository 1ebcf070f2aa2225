// "Adding a bending law touches one unit" (issue 10): a network model is the list of its terms
// (discrete/network.hpp NetworkTerm); the production models are network_terms(net), and a test
// builds its own model from a list that swaps in a test-only bending law, through the same
// interface, and stretches it with the production driver (run_stretch).
#include <gtest/gtest.h>

#include <cmath>

#include "discrete/network.hpp"
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

/// The production list with its bending term replaced by the quartic umbrella: the one unit a
/// new law adds.
std::vector<NetworkTerm> umbrella_model_terms(const Network& net) {
  std::vector<NetworkTerm> terms = network_terms(net);
  for (NetworkTerm& t : terms)
    if (t.name.rfind("bending", 0) == 0)
      t = {"bending (test-only quartic umbrella)",
           [](const Network& n, const Positions& x, const LoadState&, Positions* grad,
              EnergyBreakdown& e) {
             return e.bending = quartic_umbrella(n.topo, kUmbrella_pN_per_um3, x, grad);
           }};
  return terms;
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
}

}  // namespace
}  // namespace rbc
