// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/loop_surface.hpp"

#include <Eigen/Dense>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "core/validation.hpp"

namespace rbc {

namespace loop_surface_internal {

// One monomial c u^a v^b w^c of a box-spline basis function (times 1/12).
struct LoopMonomial {
  double coef;
  int a, b, c;
};

// The 12 basis functions of the regular patch (Stam 1998; Cirak, Ortiz and Schroeder 2000,
// appendix), 12 N_i as sums of monomials of degree 4 in (u, v, w), u = 1 - v - w.
// clang-format off
const std::vector<LoopMonomial> kBoxSpline[12] = {
  {{1, 4, 0, 0}, {2, 3, 1, 0}},
  {{1, 4, 0, 0}, {2, 3, 0, 1}},
  {{1, 4, 0, 0}, {2, 3, 0, 1}, {6, 3, 1, 0}, {6, 2, 1, 1}, {12, 2, 2, 0}, {6, 1, 2, 1},
   {6, 1, 3, 0}, {2, 0, 3, 1}, {1, 0, 4, 0}},
  {{6, 4, 0, 0}, {24, 3, 0, 1}, {24, 2, 0, 2}, {8, 1, 0, 3}, {1, 0, 0, 4}, {24, 3, 1, 0},
   {60, 2, 1, 1}, {36, 1, 1, 2}, {6, 0, 1, 3}, {24, 2, 2, 0}, {36, 1, 2, 1}, {12, 0, 2, 2},
   {8, 1, 3, 0}, {6, 0, 3, 1}, {1, 0, 4, 0}},
  {{1, 4, 0, 0}, {6, 3, 0, 1}, {12, 2, 0, 2}, {6, 1, 0, 3}, {1, 0, 0, 4}, {2, 3, 1, 0},
   {6, 2, 1, 1}, {6, 1, 1, 2}, {2, 0, 1, 3}},
  {{2, 1, 3, 0}, {1, 0, 4, 0}},
  {{1, 4, 0, 0}, {6, 3, 0, 1}, {12, 2, 0, 2}, {6, 1, 0, 3}, {1, 0, 0, 4}, {8, 3, 1, 0},
   {36, 2, 1, 1}, {36, 1, 1, 2}, {8, 0, 1, 3}, {24, 2, 2, 0}, {60, 1, 2, 1}, {24, 0, 2, 2},
   {24, 1, 3, 0}, {24, 0, 3, 1}, {6, 0, 4, 0}},
  {{1, 4, 0, 0}, {8, 3, 0, 1}, {24, 2, 0, 2}, {24, 1, 0, 3}, {6, 0, 0, 4}, {6, 3, 1, 0},
   {36, 2, 1, 1}, {60, 1, 1, 2}, {24, 0, 1, 3}, {12, 2, 2, 0}, {36, 1, 2, 1}, {24, 0, 2, 2},
   {6, 1, 3, 0}, {8, 0, 3, 1}, {1, 0, 4, 0}},
  {{2, 1, 0, 3}, {1, 0, 0, 4}},
  {{2, 0, 3, 1}, {1, 0, 4, 0}},
  {{2, 1, 0, 3}, {1, 0, 0, 4}, {6, 1, 1, 2}, {6, 0, 1, 3}, {6, 1, 2, 1}, {12, 0, 2, 2},
   {2, 1, 3, 0}, {6, 0, 3, 1}, {1, 0, 4, 0}},
  {{1, 0, 0, 4}, {2, 0, 1, 3}},
};
// clang-format on

// p^k and its first two derivatives, 0 for negative powers.
double pw(double x, int k) {
  return k < 0 ? 0.0 : (k == 0 ? 1.0 : std::pow(x, k));
}

// Value and derivatives d/dv, d/dw, d2/dv2, d2/dvdw, d2/dw2 of u^a v^b w^c with u = 1 - v - w.
// With d/dv = -d/du + d/dv|_u and d/dw = -d/du + d/dw|_u (partials of the three-variable
// monomial).
Eigen::Matrix<double, 6, 1> monomial(double v, double w, int a, int b, int c) {
  const double u = 1.0 - v - w;
  auto m = [&](int da, int db, int dc) {
    // d^(da+db+dc) / du^da dv^db dw^dc of u^a v^b w^c
    double f = 1.0;
    for (int k = 0; k < da; ++k) f *= a - k;
    for (int k = 0; k < db; ++k) f *= b - k;
    for (int k = 0; k < dc; ++k) f *= c - k;
    if (f == 0.0) return 0.0;
    return f * pw(u, a - da) * pw(v, b - db) * pw(w, c - dc);
  };
  Eigen::Matrix<double, 6, 1> r;
  r(0) = m(0, 0, 0);
  r(1) = -m(1, 0, 0) + m(0, 1, 0);
  r(2) = -m(1, 0, 0) + m(0, 0, 1);
  r(3) = m(2, 0, 0) - 2 * m(1, 1, 0) + m(0, 2, 0);
  r(4) = m(2, 0, 0) - m(1, 1, 0) - m(1, 0, 1) + m(0, 1, 1);
  r(5) = m(2, 0, 0) - 2 * m(1, 0, 1) + m(0, 0, 2);
  return r;
}

// The edge (a, b)'s index in topo (vertex_edges of a).
int edge_of(const Topology& topo, int a, int b) {
  for (const int* e = topo.vertex_edges.begin(a); e != topo.vertex_edges.end(a); ++e) {
    const int p = topo.edges(0, *e), q = topo.edges(1, *e);
    if ((p == a && q == b) || (p == b && q == a)) return *e;
  }
  throw std::logic_error("loop subdivision: no edge between two vertices of a face");
}

std::vector<bool> regular_faces(const Topology& topo) {
  std::vector<bool> r(topo.num_faces());
  for (int f = 0; f < topo.num_faces(); ++f) {
    bool reg = true;
    for (int k = 0; k < 3; ++k) reg = reg && topo.vertex_neighbours.size(topo.faces(k, f)) == 6;
    r[f] = reg;
  }
  return r;
}

}  // namespace loop_surface_internal

double loop_vertex_weight(int valence) {
  const double c = 3.0 / 8.0 + 0.25 * std::cos(2.0 * std::numbers::pi / valence);
  return (5.0 / 8.0 - c * c) / valence;
}

Eigen::Matrix<double, 6, 12> loop_box_spline(double v, double w) {
  Eigen::Matrix<double, 6, 12> n = Eigen::Matrix<double, 6, 12>::Zero();
  for (int i = 0; i < 12; ++i)
    for (const loop_surface_internal::LoopMonomial& t : loop_surface_internal::kBoxSpline[i])
      n.col(i) += t.coef * loop_surface_internal::monomial(v, w, t.a, t.b, t.c);
  return n / 12.0;
}

Adjacency loop_ordered_rings(const Topology& topo) {
  const int n = topo.num_vertices;
  Adjacency rings;
  rings.offsets.assign(n + 1, 0);
  for (int v = 0; v < n; ++v) rings.offsets[v + 1] = rings.offsets[v] + topo.vertex_faces.size(v);
  rings.items.assign(rings.offsets[n], -1);
  std::vector<std::pair<int, int>> next;  // (p, q): face (v, p, q) seen from v
  for (int v = 0; v < n; ++v) {
    next.clear();
    for (const int* f = topo.vertex_faces.begin(v); f != topo.vertex_faces.end(v); ++f) {
      int k = 0;
      while (topo.faces(k, *f) != v) ++k;
      next.emplace_back(topo.faces((k + 1) % 3, *f), topo.faces((k + 2) % 3, *f));
    }
    int* out = rings.items.data() + rings.offsets[v];
    const int deg = static_cast<int>(next.size());
    int cur = next.front().first;
    for (int i = 0; i < deg; ++i) {
      out[i] = cur;
      const auto it =
          std::find_if(next.begin(), next.end(), [&](auto& pq) { return pq.first == cur; });
      if (it == next.end()) throw std::logic_error("loop subdivision: a vertex fan is not closed");
      cur = it->second;
    }
  }
  return rings;
}

std::array<int, 12> loop_regular_patch(const Topology& topo, const Adjacency& rings, int f) {
  const int a = topo.faces(0, f), b = topo.faces(1, f), c = topo.faces(2, f);
  // The ring of `v` (valence 6), rotated to start at `first`.
  auto ring_from = [&](int v, int first) {
    std::array<int, 6> r{};
    const int* ring = rings.begin(v);
    if (rings.size(v) != 6) throw std::logic_error("loop_regular_patch: a corner of valence != 6");
    int s = 0;
    while (ring[s] != first) ++s;
    for (int i = 0; i < 6; ++i) r[i] = ring[(s + i) % 6];
    return r;
  };
  const auto ra = ring_from(a, b), rb = ring_from(b, c), rc = ring_from(c, a);
  std::array<int, 12> p{};
  p[3] = a, p[6] = b, p[7] = c;
  p[4] = ra[2], p[1] = ra[3], p[0] = ra[4], p[2] = ra[5];
  p[5] = rb[3], p[9] = rb[4], p[10] = rb[5];
  p[11] = rc[3], p[8] = rc[4];
  if (rb[2] != p[2] || rc[2] != p[10] || rc[5] != p[4])
    throw std::logic_error("loop_regular_patch: the rings of a regular face do not close");
  return p;
}

LoopSubdivision::LoopSubdivision(const Topology& topo, int max_levels) : max_levels_(max_levels) {
  require_integer_in_range("Loop subdivision levels", max_levels, 0, 8);
  Level l0;
  l0.topo = topo;
  l0.rings = loop_ordered_rings(topo);
  l0.regular_face = loop_surface_internal::regular_faces(topo);
  levels_.push_back(std::move(l0));
}

namespace loop_surface_internal {

// One level of Loop subdivision of topo: the subdivision matrix S (fine vertices from coarse:
// the n old ones, then one per edge, n + e) and the fine faces (4 f + k: the corner children
// at a, b, c, then the middle one).
struct LoopStep {
  Eigen::SparseMatrix<double, Eigen::RowMajor> s;
  Faces faces;
};
LoopStep loop_step(const Topology& t) {
  const int n = t.num_vertices, ne = t.num_edges(), nf = t.num_faces();
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(7 * n + 4 * ne);
  for (int v = 0; v < n; ++v) {
    const int deg = t.vertex_neighbours.size(v);
    const double beta = loop_vertex_weight(deg);
    trip.emplace_back(v, v, 1.0 - deg * beta);
    for (const int* j = t.vertex_neighbours.begin(v); j != t.vertex_neighbours.end(v); ++j)
      trip.emplace_back(v, *j, beta);
  }
  for (int e = 0; e < ne; ++e) {
    trip.emplace_back(n + e, t.edges(0, e), 3.0 / 8.0);
    trip.emplace_back(n + e, t.edges(1, e), 3.0 / 8.0);
    trip.emplace_back(n + e, t.edge_opposite(0, e), 1.0 / 8.0);
    trip.emplace_back(n + e, t.edge_opposite(1, e), 1.0 / 8.0);
  }
  LoopStep step;
  step.s.resize(n + ne, n);
  step.s.setFromTriplets(trip.begin(), trip.end());
  step.faces.resize(3, 4 * nf);
  for (int f = 0; f < nf; ++f) {
    const int a = t.faces(0, f), b = t.faces(1, f), c = t.faces(2, f);
    const int mab = n + edge_of(t, a, b), mbc = n + edge_of(t, b, c), mca = n + edge_of(t, c, a);
    step.faces.col(4 * f + 0) << a, mab, mca;
    step.faces.col(4 * f + 1) << mab, b, mbc;
    step.faces.col(4 * f + 2) << mca, mbc, c;
    step.faces.col(4 * f + 3) << mab, mbc, mca;
  }
  return step;
}

}  // namespace loop_surface_internal

TriMesh loop_subdivide(const TriMesh& mesh) {
  const loop_surface_internal::LoopStep step = loop_surface_internal::loop_step(mesh.topo);
  TriMesh fine;
  fine.topo = build_topology(step.faces, static_cast<int>(step.s.rows()));
  fine.x = (step.s * mesh.x.transpose()).transpose();
  return fine;
}

void LoopSubdivision::build_next_level() {
  const Level& c = levels_.back();
  loop_surface_internal::LoopStep step = loop_surface_internal::loop_step(c.topo);
  Level fine;
  fine.topo = build_topology(step.faces, static_cast<int>(step.s.rows()));
  fine.rings = loop_ordered_rings(fine.topo);
  fine.regular_face = loop_surface_internal::regular_faces(fine.topo);
  if (levels_.size() == 1)
    fine.from_control = std::move(step.s);
  else
    fine.from_control = (step.s * c.from_control).pruned();
  levels_.push_back(std::move(fine));
}

LoopBasis LoopSubdivision::basis(int f, double v, double w) {
  const Topology& t0 = levels_.front().topo;
  if (f < 0 || f >= t0.num_faces())
    throw InvalidParameter(
        "Loop basis face", std::to_string(f),
        "a face of the control mesh, 0 to " + std::to_string(t0.num_faces() - 1));
  if (!(v > 0 && w > 0 && v + w < 1))
    throw InvalidParameter("Loop basis point (v, w)", std::to_string(v) + ", " + std::to_string(w),
                           "strictly inside the face: v, w > 0 and v + w < 1");
  using Vec2 = Eigen::Vector2d;
  std::array<Vec2, 3> corner = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1)};  // in the root's (v, w)
  const Vec2 xi(v, w);
  int face = f;
  for (int level = 0;; ++level) {
    if (level >= static_cast<int>(levels_.size())) build_next_level();
    const Level& lv = levels_[level];
    Eigen::Matrix2d jm;
    jm.col(0) = corner[1] - corner[0];
    jm.col(1) = corner[2] - corner[0];
    const Eigen::Matrix2d a = jm.inverse();
    const Vec2 loc = a * (xi - corner[0]);
    if (lv.regular_face[face]) {
      const std::array<int, 12> patch = loop_regular_patch(lv.topo, lv.rings, face);
      const Eigen::Matrix<double, 6, 12> nl = loop_box_spline(loc(0), loc(1));
      // Chain rule to the root's parameters: d/dxi_k = sum_m A(m, k) d/dl_m.
      Eigen::Matrix<double, 6, 12> nx;
      nx.row(0) = nl.row(0);
      for (int k = 0; k < 2; ++k) nx.row(1 + k) = a(0, k) * nl.row(1) + a(1, k) * nl.row(2);
      const int second[3][2] = {{0, 0}, {0, 1}, {1, 1}};
      for (int r = 0; r < 3; ++r) {
        const int k = second[r][0], j = second[r][1];
        nx.row(3 + r) = a(0, k) * a(0, j) * nl.row(3) +
                        (a(0, k) * a(1, j) + a(1, k) * a(0, j)) * nl.row(4) +
                        a(1, k) * a(1, j) * nl.row(5);
      }
      LoopBasis out;
      if (level == 0) {
        out.vertices.assign(patch.begin(), patch.end());
        out.shape = nx;
        return out;
      }
      // Map the fine patch's control points to the control mesh's.
      std::vector<std::pair<int, int>> order;  // (control vertex, column)
      std::vector<Eigen::Matrix<double, 6, 1>> cols;
      for (int k = 0; k < 12; ++k) {
        for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(lv.from_control,
                                                                            patch[k]);
             it; ++it) {
          auto pos =
              std::find(out.vertices.begin(), out.vertices.end(), static_cast<int>(it.col()));
          if (pos == out.vertices.end()) {
            out.vertices.push_back(static_cast<int>(it.col()));
            cols.push_back(it.value() * nx.col(k));
          } else {
            cols[pos - out.vertices.begin()] += it.value() * nx.col(k);
          }
        }
      }
      out.shape.resize(6, static_cast<Eigen::Index>(cols.size()));
      for (std::size_t k = 0; k < cols.size(); ++k) out.shape.col(k) = cols[k];
      return out;
    }
    if (level + 1 > max_levels_)
      throw InvalidParameter("Loop basis point (v, w)",
                             std::to_string(v) + ", " + std::to_string(w),
                             "a point reached within " + std::to_string(max_levels_) +
                                 " subdivision levels (it lies too near an irregular corner)");
    // The child that holds the point.
    const double lu = 1.0 - loc(0) - loc(1);
    const Vec2 mab = 0.5 * (corner[0] + corner[1]), mbc = 0.5 * (corner[1] + corner[2]),
               mca = 0.5 * (corner[2] + corner[0]);
    int child = 3;
    if (lu > 0.5)
      child = 0, corner = {corner[0], mab, mca};
    else if (loc(0) > 0.5)
      child = 1, corner = {mab, corner[1], mbc};
    else if (loc(1) > 0.5)
      child = 2, corner = {mca, mbc, corner[2]};
    else
      corner = {mab, mbc, mca};
    face = 4 * face + child;
  }
}

Eigen::SparseMatrix<double> loop_limit_matrix(const Topology& topo) {
  std::vector<Eigen::Triplet<double>> trip;
  for (int v = 0; v < topo.num_vertices; ++v) {
    const int deg = topo.vertex_neighbours.size(v);
    const double chi = 1.0 / (3.0 / (8.0 * loop_vertex_weight(deg)) + deg);
    trip.emplace_back(v, v, 1.0 - deg * chi);
    for (const int* j = topo.vertex_neighbours.begin(v); j != topo.vertex_neighbours.end(v); ++j)
      trip.emplace_back(v, *j, chi);
  }
  Eigen::SparseMatrix<double> l(topo.num_vertices, topo.num_vertices);
  l.setFromTriplets(trip.begin(), trip.end());
  return l;
}

Eigen::SparseMatrix<double> loop_limit_sampling_matrix(const Topology& topo, int levels) {
  require_integer_in_range("Loop sampling levels", levels, 0, 6);
  Topology t = topo;
  Eigen::SparseMatrix<double, Eigen::RowMajor> w(topo.num_vertices, topo.num_vertices);
  w.setIdentity();
  for (int l = 0; l < levels; ++l) {
    loop_surface_internal::LoopStep step = loop_surface_internal::loop_step(t);
    w = (step.s * w).pruned();
    t = build_topology(step.faces, static_cast<int>(step.s.rows()));
  }
  return Eigen::SparseMatrix<double>(loop_limit_matrix(t) * w);
}

Positions loop_interpolating_control_points(const Topology& topo, const Positions& points_um) {
  if (points_um.cols() != topo.num_vertices)
    throw InvalidParameter("interpolated points", std::to_string(points_um.cols()),
                           "one per vertex (" + std::to_string(topo.num_vertices) + ")");
  Eigen::SparseMatrix<double> l = loop_limit_matrix(topo);
  l.makeCompressed();
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu(l);
  if (lu.info() != Eigen::Success)
    throw std::runtime_error("loop_interpolating_control_points: the limit matrix is singular");
  Eigen::MatrixXd rhs = points_um.transpose();
  const Eigen::MatrixXd x = lu.solve(rhs);
  return x.transpose();
}

std::vector<LoopQuadraturePoint> loop_quadrature(const Topology& topo) {
  LoopSubdivision sub(topo, 2);
  const double pts[3][2] = {{1.0 / 6, 1.0 / 6}, {2.0 / 3, 1.0 / 6}, {1.0 / 6, 2.0 / 3}};
  std::vector<LoopQuadraturePoint> q;
  q.reserve(3 * topo.num_faces());
  for (int f = 0; f < topo.num_faces(); ++f)
    for (const auto& p : pts) q.push_back({f, p[0], p[1], 1.0 / 6.0, sub.basis(f, p[0], p[1])});
  return q;
}

}  // namespace rbc
