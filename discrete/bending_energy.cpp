// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/bending_energy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "core/geometry.hpp"
#include "core/parallel.hpp"
#include "core/units.hpp"
#include "core/validation.hpp"
#include "discrete/element_hessian.hpp"
#include "discrete/network_energy.hpp"

namespace rbc {

void BendingParameters::validate() const {
  require_finite_in_range("bending rigidity kappa", "J", kappa_pNum / units::pNum_per_J, 0.0,
                          kMaxKappa_J, Ends::closed_closed);
  require_finite_in_range("spontaneous curvature H0", "1/um", h0_per_um,
                          -kMaxSpontaneousCurvature_per_um, kMaxSpontaneousCurvature_per_um,
                          Ends::closed_closed);
}

std::string to_string(BendingModel m) {
  return m == BendingModel::juelicher ? "juelicher" : "dihedral";
}

BendingModel bending_model_from_string(const std::string& name) {
  if (name == "juelicher") return BendingModel::juelicher;
  if (name == "dihedral") return BendingModel::dihedral;
  throw std::invalid_argument("bending model '" + name + "' is not one of juelicher, dihedral");
}

double dihedral_stiffness_pNum(double kappa_pNum, DihedralMapping mapping) {
  return mapping == DihedralMapping::sphere_matched ? 2.0 * units::sqrt3 * kappa_pNum
                                                    : 2.0 * kappa_pNum / units::sqrt3;
}

double hinge_length_angle(const Positions& x, const Topology& topo, int e,
                          Eigen::Matrix<double, 3, 4>* grad) {
  const int a = topo.edges(0, e), b = topo.edges(1, e);
  const int c = topo.edge_opposite(0, e), d = topo.edge_opposite(1, e);
  Eigen::Matrix<double, 3, 4> gt;
  const double theta = dihedral_angle(x.col(a), x.col(b), x.col(c), x.col(d), grad ? &gt : nullptr);
  const Eigen::Vector3d ab = x.col(b) - x.col(a);
  const double len = ab.norm();
  if (grad) {
    *grad = len * gt;
    grad->col(1) += theta * ab / len;
    grad->col(0) -= theta * ab / len;
  }
  return len * theta;
}

std::vector<JuelicherCell> juelicher_cells(const Topology& topo, const BendingParameters& p,
                                           const std::vector<double>& lt,
                                           const std::vector<double>& af) {
  const int nv = topo.num_vertices;
  std::vector<JuelicherCell> cells(nv);
#pragma omp parallel for schedule(static) if (nv >= kParallelElements)
  for (int v = 0; v < nv; ++v) {
    cells[v] = juelicher_vertex_cell(
        topo, p, v, [&](int e) { return lt[e]; }, [&](int f) { return af[f]; });
  }
  return cells;
}

double juelicher_bending_energy(const Positions& x, const Topology& topo,
                                const BendingParameters& p, Positions* grad) {
  const int nv = topo.num_vertices, ne = topo.num_edges(), nf = topo.num_faces();
  std::vector<double> lt(ne), af(nf);
  // With a gradient, each hinge's d(L theta) is kept from this pass (the angle and its
  // atan2 were half of a stretch's time when computed twice).
  std::vector<Eigen::Matrix<double, 3, 4>> glt(grad ? ne : 0);
#pragma omp parallel for schedule(static) if (ne >= kParallelElements)
  for (int e = 0; e < ne; ++e) lt[e] = hinge_length_angle(x, topo, e, grad ? &glt[e] : nullptr);
#pragma omp parallel for schedule(static) if (nf >= kParallelElements)
  for (int f = 0; f < nf; ++f) {
    const auto& t = topo.faces.col(f);
    af[f] = triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  }
  const std::vector<JuelicherCell> cells = juelicher_cells(topo, p, lt, af);
  // Deterministic sum (core/parallel.hpp): the same bits with any thread count.
  const double energy = sum_parallel(nv, [&](int v) { return cells[v].energy_pNum; });
  if (!grad) return energy;
  // dE = kappa sum_i h_i (dM_i - H0 dA_i) - kappa/2 h_i^2 dA_i, with dM_i = 1/2 sum d(L theta)
  // over the vertex's edges and dA_i = 1/3 sum dA_f over its faces.
  const auto h = [&](int v) { return cells[v].h_per_um; };
  assemble_parallel(ne, grad, [&](int e, Positions& g) {
    const Eigen::Matrix<double, 3, 4>& gl = glt[e];
    const double coef = juelicher_hinge_coef(p, h(topo.edges(0, e)), h(topo.edges(1, e)));
    g.col(topo.edges(0, e)) += coef * gl.col(0);
    g.col(topo.edges(1, e)) += coef * gl.col(1);
    g.col(topo.edge_opposite(0, e)) += coef * gl.col(2);
    g.col(topo.edge_opposite(1, e)) += coef * gl.col(3);
    return 0.0;
  });
  assemble_parallel(nf, grad, [&](int f, Positions& g) {
    const auto& t = topo.faces.col(f);
    Eigen::Matrix3d ga;
    triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)), &ga);
    const double hf[3] = {h(t(0)), h(t(1)), h(t(2))};
    const double coef = juelicher_face_coef(p, hf);
    for (int k = 0; k < 3; ++k) g.col(t(k)) += coef * ga.col(k);
    return 0.0;
  });
  return energy;
}

double juelicher_bending_energy(const Topology& topo, const BendingParameters& p,
                                const NetworkGeometry& geo, GeometricGradient* grad) {
  const int nv = topo.num_vertices, ne = topo.num_edges(), nf = topo.num_faces();
  // The cells and their energy in one chunked pass (sum_parallel's chunks: the same bits), with
  // L_e theta_e formed where it is summed; then the hinge and face coefficients in one region.
  Eigen::VectorXd h(nv);  // h_v = H_v - H0 (1/um), every entry written below
  double partial[kMaxChunks] = {0, 0, 0, 0};
  // In blocks: the star sums gathered first (juelicher_vertex_sums), then the cells in a loop the
  // compiler vectorises (two divisions a cell), then their energies summed in order.
  for_each_chunk(nv, [&](int c, int begin, int end) {
    constexpr int kBlock = 128;
    double m[kBlock], a[kBlock], e[kBlock];
    double s = 0;
    for (int b0 = begin; b0 < end; b0 += kBlock) {
      const int n = std::min(kBlock, end - b0);
      for (int i = 0; i < n; ++i)
        juelicher_vertex_sums(
            topo, b0 + i, [&](int k) { return geo.edge_length[k] * geo.hinge_angle[k]; },
            [&](int f) { return geo.face_area[f]; }, m[i], a[i]);
      double* __restrict hb = h.data() + b0;
      for (int i = 0; i < n; ++i) {
        const JuelicherCell cell = juelicher_cell(p, m[i], a[i]);
        e[i] = cell.energy_pNum;
        hb[i] = cell.h_per_um;
      }
      for (int i = 0; i < n; ++i) s += e[i];
    }
    partial[c] = s;
  });
  double energy = 0.0;
  for (int c = 0; c < assembly_chunks(nv); ++c) energy += partial[c];
  if (!grad) return energy;
  const auto hinges = [&](int, int begin, int end) {
    for (int e = begin; e < end; ++e) {
      const double c = juelicher_hinge_coef(p, h[topo.edges(0, e)], h[topo.edges(1, e)]);
      grad->hinge_angle[e] += c * geo.edge_length[e];
      grad->edge_length[e] += c * geo.hinge_angle[e];
    }
  };
  const auto faces = [&](int, int begin, int end) {
    for (int f = begin; f < end; ++f) {
      const double hf[3] = {h[topo.faces(0, f)], h[topo.faces(1, f)], h[topo.faces(2, f)]};
      grad->face_area[f] = juelicher_face_coef(p, hf, grad->face_area[f]);
    }
  };
  for_each_chunk_pair(ne, hinges, nf, faces, Then::independent);
  return energy;
}

namespace {

int star_slot(const VertexStars& s, int v, int w) {
  for (int k = 0; k < s.size(v); ++k)
    if (s.begin(v)[k] == w) return k;
  throw std::logic_error("vertex outside its star");  // topology invariant
}

}  // namespace

VertexStars make_vertex_stars(const Topology& t) {
  const int n = t.num_vertices;
  VertexStars s;
  s.offsets.assign(n + 1, 0);
  for (int v = 0; v < n; ++v) {
    s.vertices.push_back(v);
    s.vertices.insert(s.vertices.end(), t.vertex_neighbours.begin(v), t.vertex_neighbours.end(v));
    s.offsets[v + 1] = static_cast<int>(s.vertices.size());
  }
  s.hinge_slots.reserve(4 * t.vertex_edges.items.size());
  s.face_slots.reserve(3 * t.vertex_faces.items.size());
  for (int v = 0; v < n; ++v) {
    for (const int* e = t.vertex_edges.begin(v); e != t.vertex_edges.end(v); ++e)
      for (int id :
           {t.edges(0, *e), t.edges(1, *e), t.edge_opposite(0, *e), t.edge_opposite(1, *e)})
        s.hinge_slots.push_back(star_slot(s, v, id));
    for (const int* f = t.vertex_faces.begin(v); f != t.vertex_faces.end(v); ++f)
      for (int k = 0; k < 3; ++k) s.face_slots.push_back(star_slot(s, v, t.faces(k, *f)));
  }
  return s;
}

double JuelicherHessianTerms::hinge_coef(const Topology& t, int e) const {
  return juelicher_hinge_coef(params, cells[t.edges(0, e)].h_per_um, cells[t.edges(1, e)].h_per_um);
}

double JuelicherHessianTerms::add_face_coef(const Topology& t, int f, double coef) const {
  const double h[3] = {cells[t.faces(0, f)].h_per_um, cells[t.faces(1, f)].h_per_um,
                       cells[t.faces(2, f)].h_per_um};
  return juelicher_face_coef(params, h, coef);
}

void JuelicherHessianTerms::cell_gradient(const Topology& t, const VertexStars& stars, int v,
                                          double* u) const {
  std::fill(u, u + 3 * stars.size(v), 0.0);
  const int e0 = t.vertex_edges.offsets[v], f0 = t.vertex_faces.offsets[v];
  for (int k = 0; k < t.vertex_edges.size(v); ++k) {
    const int e = t.vertex_edges.items[e0 + k];
    for (int q = 0; q < 4; ++q)
      Eigen::Map<Eigen::Vector3d>(u + 3 * stars.hinge_slots[4 * (e0 + k) + q]) +=
          0.5 * dq[e].col(q);
  }
  const double c = -(params.h0_per_um + cells[v].h_per_um) / 3.0;
  for (int k = 0; k < t.vertex_faces.size(v); ++k) {
    const int f = t.vertex_faces.items[f0 + k];
    for (int q = 0; q < 3; ++q)
      Eigen::Map<Eigen::Vector3d>(u + 3 * stars.face_slots[3 * (f0 + k) + q]) += c * da[f].col(q);
  }
}

JuelicherHessianTerms juelicher_hessian_terms(const Positions& x, const Topology& t,
                                              const BendingParameters& p) {
  const int ne = t.num_edges(), nf = t.num_faces();
  JuelicherHessianTerms r;
  r.params = p;
  std::vector<double> lt(ne), af(nf);
  r.dq.resize(ne);
  r.da.resize(nf);
#pragma omp parallel for schedule(static)
  for (int e = 0; e < ne; ++e) lt[e] = hinge_length_angle(x, t, e, &r.dq[e]);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f)
    af[f] =
        triangle_area(x.col(t.faces(0, f)), x.col(t.faces(1, f)), x.col(t.faces(2, f)), &r.da[f]);
  r.cells = juelicher_cells(t, p, lt, af);
  return r;
}

void add_juelicher_hessian(const Positions& x, const Topology& t, const BendingParameters& p,
                           BlockMatrix& h) {
  const int nv = t.num_vertices, ne = t.num_edges(), nf = t.num_faces();
  const JuelicherHessianTerms terms = juelicher_hessian_terms(x, t, p);
  std::vector<Matrix12d> hq(ne);
  std::vector<Matrix9d> ha(nf);
#pragma omp parallel for schedule(static)
  for (int e = 0; e < ne; ++e) {
    hinge_length_angle_hessian(x.col(t.edges(0, e)), x.col(t.edges(1, e)),
                               x.col(t.edge_opposite(0, e)), x.col(t.edge_opposite(1, e)), nullptr,
                               &hq[e]);
    hq[e] *= terms.hinge_coef(t, e);
  }
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    triangle_area_hessian(x.col(t.faces(0, f)), x.col(t.faces(1, f)), x.col(t.faces(2, f)), nullptr,
                          &ha[f]);
    ha[f] *= terms.add_face_coef(t, f);
  }
  for (int e = 0; e < ne; ++e) {
    const int verts[4] = {t.edges(0, e), t.edges(1, e), t.edge_opposite(0, e),
                          t.edge_opposite(1, e)};
    h.add_local<4>(verts, hq[e]);
  }
  for (int f = 0; f < nf; ++f) {
    const int verts[3] = {t.faces(0, f), t.faces(1, f), t.faces(2, f)};
    h.add_local<3>(verts, ha[f]);
  }
  // Rank-one cell terms (kappa/A_v) u_v u_v^T over the closed star of v.
  const VertexStars stars = make_vertex_stars(t);
  std::vector<int> star;
  Eigen::VectorXd u;
  for (int v = 0; v < nv; ++v) {
    star.assign(stars.begin(v), stars.begin(v) + stars.size(v));
    u.resize(3 * static_cast<Eigen::Index>(star.size()));
    terms.cell_gradient(t, stars, v, u.data());
    h.add_outer(star, u, terms.cell_weight(v));
  }
}

double dihedral_hinge_energy(const Positions& x, const Topology& topo, double kb, double theta0,
                             int e, Eigen::Matrix<double, 3, 4>* grad) {
  const int a = topo.edges(0, e), b = topo.edges(1, e);
  const int c = topo.edge_opposite(0, e), d = topo.edge_opposite(1, e);
  const double theta = dihedral_angle(x.col(a), x.col(b), x.col(c), x.col(d), grad);
  if (grad) *grad *= kb * std::sin(theta - theta0);  // dE/dtheta dtheta/dx
  return kb * (1.0 - std::cos(theta - theta0));
}

double dihedral_bending_energy(const Positions& x, const Topology& topo, double kb, double theta0,
                               Positions* grad) {
  return assemble_parallel(topo.num_edges(), grad, [&](int e, Positions& g) {
    Eigen::Matrix<double, 3, 4> gh;
    const double energy = dihedral_hinge_energy(x, topo, kb, theta0, e, grad ? &gh : nullptr);
    if (grad) {
      g.col(topo.edges(0, e)) += gh.col(0);
      g.col(topo.edges(1, e)) += gh.col(1);
      g.col(topo.edge_opposite(0, e)) += gh.col(2);
      g.col(topo.edge_opposite(1, e)) += gh.col(3);
    }
    return energy;
  });
}

}  // namespace rbc
