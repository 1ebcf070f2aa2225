#include "continuum/helfrich_hessian.hpp"

#include <algorithm>
#include <vector>

#include "continuum/geometry_hessian.hpp"
#include "continuum/hinge_hessian.hpp"

namespace rbc {

void add_juelicher_hessian(const Positions& x, const Topology& topo, const BendingParameters& p,
                           BlockHessian& h, double scale) {
  const int nv = topo.num_vertices, ne = topo.num_edges(), nf = topo.num_faces();
  const double kappa = scale * p.kappa_pNum, h0 = p.h0_per_um;
  std::vector<double> q(ne), af(nf);
  std::vector<Eigen::Matrix<double, 3, 4>> gq(ne);
  std::vector<Matrix12d> hq(ne);
  std::vector<Vector9d> ga(nf);
  std::vector<Matrix9d> ha(nf);
#pragma omp parallel for schedule(static)
  for (int e = 0; e < ne; ++e)
    q[e] = hinge_length_angle_hessian(x.col(topo.edges(0, e)), x.col(topo.edges(1, e)),
                                      x.col(topo.edge_opposite(0, e)),
                                      x.col(topo.edge_opposite(1, e)), &gq[e], &hq[e]);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    const auto t = topo.faces.col(f);
    af[f] = triangle_area_hessian(x.col(t(0)), x.col(t(1)), x.col(t(2)), &ga[f], &ha[f]);
  }
  std::vector<double> mv(nv, 0.0), av(nv, 0.0), hv(nv);
  for (int v = 0; v < nv; ++v) {
    for (const int* e = topo.vertex_edges.begin(v); e != topo.vertex_edges.end(v); ++e)
      mv[v] += 0.5 * q[*e];
    for (const int* f = topo.vertex_faces.begin(v); f != topo.vertex_faces.end(v); ++f)
      av[v] += af[*f] / 3.0;
    hv[v] = (mv[v] - h0 * av[v]) / av[v];
  }
  // Curvature terms of the hinges and faces.
  for (int e = 0; e < ne; ++e) {
    const int verts[4] = {topo.edges(0, e), topo.edges(1, e), topo.edge_opposite(0, e),
                          topo.edge_opposite(1, e)};
    h.add_local<4>(verts, Matrix12d(0.5 * kappa * (hv[verts[0]] + hv[verts[1]]) * hq[e]));
  }
  for (int f = 0; f < nf; ++f) {
    const int verts[3] = {topo.faces(0, f), topo.faces(1, f), topo.faces(2, f)};
    double coef = 0.0;
    for (int k : verts) coef -= kappa * (h0 * hv[k] + 0.5 * hv[k] * hv[k]) / 3.0;
    h.add_local<3>(verts, Matrix9d(coef * ha[f]));
  }
  // Rank-one vertex-cell terms (kappa/A_v) u_v u_v^T over the closed star of v.
  std::vector<int> star;
  Eigen::VectorXd u;
  for (int v = 0; v < nv; ++v) {
    star.assign(1, v);
    star.insert(star.end(), topo.vertex_neighbours.begin(v), topo.vertex_neighbours.end(v));
    u.setZero(3 * static_cast<Eigen::Index>(star.size()));
    const auto local = [&](int w) {
      return static_cast<int>(std::find(star.begin(), star.end(), w) - star.begin());
    };
    for (const int* e = topo.vertex_edges.begin(v); e != topo.vertex_edges.end(v); ++e) {
      const int verts[4] = {topo.edges(0, *e), topo.edges(1, *e), topo.edge_opposite(0, *e),
                            topo.edge_opposite(1, *e)};
      for (int k = 0; k < 4; ++k) u.segment<3>(3 * local(verts[k])) += 0.5 * gq[*e].col(k);
    }
    const double c = -(h0 + hv[v]) / 3.0;
    for (const int* f = topo.vertex_faces.begin(v); f != topo.vertex_faces.end(v); ++f)
      for (int k = 0; k < 3; ++k)
        u.segment<3>(3 * local(topo.faces(k, *f))) += c * ga[*f].segment<3>(3 * k);
    h.add_outer(star, u, kappa / av[v]);
  }
}

}  // namespace rbc
