#include "discrete/hessian_approximation.hpp"

#include <algorithm>
#include <vector>

#include "core/geometry.hpp"
#include "discrete/link_energy.hpp"

namespace rbc {
namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

// Adds the 3x3 block B at (block row i, block column j).
void add_block(Triplets& t, int i, int j, const Eigen::Matrix3d& b) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) t.emplace_back(3 * i + r, 3 * j + c, b(r, c));
}

}  // namespace

Eigen::SparseMatrix<double> approximate_hessian(const Network& net, const Positions& x,
                                                double shift_fraction) {
  const Topology& topo = net.topo;
  const int n = topo.num_vertices;
  Triplets t;
  t.reserve(static_cast<size_t>(topo.num_edges()) * 36 + static_cast<size_t>(n) * 500);
  // Links: d2E/dxb2 = H, d2E/dxa dxb = -H.
  for (int e = 0; e < topo.num_edges(); ++e) {
    const int a = topo.edges(0, e), b = topo.edges(1, e);
    const Eigen::Vector3d d = x.col(b) - x.col(a);
    const double lbar2 = net.lbar_um(e) * net.lbar_um(e);
    const DensityValue v = evaluate(net.wlc, d.squaredNorm() / lbar2);
    if (!std::isfinite(v.v)) continue;
    const Eigen::Matrix3d h = 1.73205080756887729353 *
                              (std::max(v.dv, 0.0) * Eigen::Matrix3d::Identity() +
                               2.0 * std::max(v.d2v, 0.0) / lbar2 * d * d.transpose());
    add_block(t, a, a, h);
    add_block(t, b, b, h);
    add_block(t, a, b, -h);
    add_block(t, b, a, -h);
  }
  // Steric faces, Gauss-Newton in J = A/Abar.
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto& c = topo.faces.col(f);
    Eigen::Matrix3d ga;
    const double area = triangle_area(x.col(c(0)), x.col(c(1)), x.col(c(2)), &ga);
    const StericDensity s =
        steric_density(net.steric_C_pN_per_um, net.steric, area / net.abar_um2(f));
    const double w = std::max(s.d2v, 0.0) / net.abar_um2(f);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) add_block(t, c(i), c(j), w * ga.col(i) * ga.col(j).transpose());
  }
  // Juelicher bending, Gauss-Newton per vertex: kappa/A_i dM_i dM_i^T over the star of i.
  if (net.bending_model == BendingModel::juelicher && net.bending.kappa_pNum > 0) {
    std::vector<int> star;
    std::vector<Eigen::Vector3d> grad;
    for (int i = 0; i < n; ++i) {
      star.assign(1, i);
      for (const int* v = topo.vertex_neighbours.begin(i); v != topo.vertex_neighbours.end(i); ++v)
        star.push_back(*v);
      grad.assign(star.size(), Eigen::Vector3d::Zero());
      auto slot = [&](int v) {
        return static_cast<int>(std::find(star.begin(), star.end(), v) - star.begin());
      };
      double area = 0;
      for (const int* f = topo.vertex_faces.begin(i); f != topo.vertex_faces.end(i); ++f) {
        const auto& c = topo.faces.col(*f);
        area += triangle_area(x.col(c(0)), x.col(c(1)), x.col(c(2))) / 3.0;
      }
      for (const int* e = topo.vertex_edges.begin(i); e != topo.vertex_edges.end(i); ++e) {
        Eigen::Matrix<double, 3, 4> g;
        hinge_length_angle(x, topo, *e, &g);
        const int ids[4] = {topo.edges(0, *e), topo.edges(1, *e), topo.edge_opposite(0, *e),
                            topo.edge_opposite(1, *e)};
        for (int k = 0; k < 4; ++k) grad[slot(ids[k])] += 0.5 * g.col(k);
      }
      const double w = net.bending.kappa_pNum / area;
      for (size_t a = 0; a < star.size(); ++a)
        for (size_t b = 0; b < star.size(); ++b)
          add_block(t, star[a], star[b], w * grad[a] * grad[b].transpose());
    }
  }
  Eigen::SparseMatrix<double> h(3 * n, 3 * n);
  h.setFromTriplets(t.begin(), t.end());
  const double shift = shift_fraction * h.diagonal().mean();
  for (int k = 0; k < 3 * n; ++k) h.coeffRef(k, k) += shift;
  return h;
}

}  // namespace rbc
