#include "discrete/network_hessian.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/block_pattern.hpp"
#include "core/geometry.hpp"
#include "discrete/link_energy.hpp"

namespace rbc {

void NetworkHessianOptions::validate() const {
  if (!(shift_fraction >= 0.0 && shift_fraction < 1.0))
    throw std::invalid_argument("Hessian shift fraction must lie in [0, 1), got " +
                                std::to_string(shift_fraction));
}

namespace {

int local_slot(const std::vector<int>& verts, int first, int size, int v) {
  for (int k = 0; k < size; ++k)
    if (verts[first + k] == v) return k;
  throw std::logic_error("vertex outside its star");  // topology invariant
}

int find_edge(const Topology& t, int a, int b) {
  for (const int* e = t.vertex_edges.begin(a); e != t.vertex_edges.end(a); ++e)
    if (t.edges(0, *e) == b || t.edges(1, *e) == b) return *e;
  throw std::logic_error("face side is not an edge");  // topology invariant
}

}  // namespace

NetworkHessian::NetworkHessian(const Network& net, const NetworkHessianOptions& options)
    : net_(&net), opt_(options) {
  opt_.validate();
  const Topology& t = net.topo;
  const int n = t.num_vertices;
  const bool juelicher = net.bending_model == BendingModel::juelicher && net.bending.kappa_pNum > 0;
  const bool dihedral = net.bending_model == BendingModel::dihedral && net.dihedral_kb_pNum > 0;

  // Rank-one groups: Juelicher vertex stars or Kantor-Nelson hinges.
  if (juelicher) {
    groups_.resize(n);
    for (int v = 0; v < n; ++v) {
      groups_[v] = {static_cast<int>(group_vertices_.size()), 1 + t.vertex_neighbours.size(v)};
      group_vertices_.push_back(v);
      group_vertices_.insert(group_vertices_.end(), t.vertex_neighbours.begin(v),
                             t.vertex_neighbours.end(v));
    }
    for (int v = 0; v < n; ++v) {
      const Group& g = groups_[v];
      for (const int* e = t.vertex_edges.begin(v); e != t.vertex_edges.end(v); ++e)
        for (int id :
             {t.edges(0, *e), t.edges(1, *e), t.edge_opposite(0, *e), t.edge_opposite(1, *e)})
          star_hinge_slots_.push_back(local_slot(group_vertices_, g.first, g.size, id));
      for (const int* f = t.vertex_faces.begin(v); f != t.vertex_faces.end(v); ++f)
        for (int k = 0; k < 3; ++k)
          star_face_slots_.push_back(local_slot(group_vertices_, g.first, g.size, t.faces(k, *f)));
    }
  } else if (dihedral) {
    groups_.resize(t.num_edges());
    for (int e = 0; e < t.num_edges(); ++e) {
      groups_[e] = {static_cast<int>(group_vertices_.size()), 4};
      for (int id : {t.edges(0, e), t.edges(1, e), t.edge_opposite(0, e), t.edge_opposite(1, e)})
        group_vertices_.push_back(id);
    }
  }

  // Lower block pattern: diagonal + edges (+ every pair of a group for two_ring).
  std::vector<std::vector<int>> cols(n);
  for (int v = 0; v < n; ++v) cols[v].push_back(v);
  for (int e = 0; e < t.num_edges(); ++e) {
    const int a = t.edges(0, e), b = t.edges(1, e);
    cols[std::min(a, b)].push_back(std::max(a, b));
  }
  if (opt_.bending_coupling == BendingCoupling::two_ring)
    for (const Group& g : groups_)
      for (int k = 0; k < g.size; ++k)
        for (int l = 0; l < g.size; ++l) {
          const int i = group_vertices_[g.first + k], j = group_vertices_[g.first + l];
          if (i > j) cols[j].push_back(i);
        }
  BlockPattern pattern = make_block_pattern(std::move(cols));
  block_col_offsets_ = std::move(pattern.col_offsets);
  block_rows_ = std::move(pattern.rows);
  m_ = std::move(pattern.matrix);
  block_start_.resize(block_rows_.size());
  block_stride_.resize(block_rows_.size());
  diagonal_block_.resize(n);
  for (int j = 0; j < n; ++j) {
    const int len = block_col_offsets_[j + 1] - block_col_offsets_[j];
    for (int k = block_col_offsets_[j]; k < block_col_offsets_[j + 1]; ++k) {
      block_start_[k] = m_.outerIndexPtr()[3 * j] + 3 * (k - block_col_offsets_[j]);
      block_stride_[k] = 3 * len;
      if (block_rows_[k] == j) diagonal_block_[j] = k;
    }
  }

  // Element placements.
  face_edges_.resize(3 * static_cast<size_t>(t.num_faces()));
  face_codes_.resize(9 * static_cast<size_t>(t.num_faces()));
  for (int f = 0; f < t.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      face_edges_[3 * f + k] = find_edge(t, t.faces(k, f), t.faces((k + 1) % 3, f));
      for (int l = 0; l < 3; ++l)
        face_codes_[9 * f + 3 * k + l] = block_code(t.faces(k, f), t.faces(l, f));
    }
  }
  group_code_offsets_.assign(groups_.size() + 1, 0);
  for (size_t g = 0; g < groups_.size(); ++g) {
    const Group& gr = groups_[g];
    for (int k = 0; k < gr.size; ++k)
      for (int l = 0; l < gr.size; ++l)
        group_codes_.push_back(
            block_code(group_vertices_[gr.first + k], group_vertices_[gr.first + l]));
    group_code_offsets_[g + 1] = static_cast<int>(group_codes_.size());
  }
  if (juelicher && opt_.hinge_curvature) {
    hinge_codes_.resize(16 * static_cast<size_t>(t.num_edges()));
    for (int e = 0; e < t.num_edges(); ++e) {
      const int id[4] = {t.edges(0, e), t.edges(1, e), t.edge_opposite(0, e),
                         t.edge_opposite(1, e)};
      for (int k = 0; k < 4; ++k)
        for (int l = 0; l < 4; ++l) hinge_codes_[16 * e + 4 * k + l] = block_code(id[k], id[l]);
    }
    hinge_k_.resize(t.num_edges());
  }
  face_k_.resize(t.num_faces());
  group_u_.resize(3 * group_vertices_.size());
  group_w_.resize(groups_.size());
}

int NetworkHessian::block_code(int i, int j) const {
  const bool transposed = i < j;
  if (transposed) std::swap(i, j);
  const auto first = block_rows_.begin() + block_col_offsets_[j];
  const auto last = block_rows_.begin() + block_col_offsets_[j + 1];
  const auto it = std::lower_bound(first, last, i);
  if (it == last || *it != i) return -1;
  return 2 * static_cast<int>(it - block_rows_.begin()) + (transposed ? 1 : 0);
}

void NetworkHessian::add(int code, const Eigen::Matrix3d& b) {
  const int blk = code >> 1;
  double* v = m_.valuePtr() + block_start_[blk];
  const int s = block_stride_[blk];
  if (code & 1) {
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) v[c * s + r] += b(c, r);
  } else {
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) v[c * s + r] += b(r, c);
  }
}

void NetworkHessian::add_diagonal(int vertex, const Eigen::Matrix3d& b) {
  add(2 * diagonal_block_[vertex], b);
}

const Eigen::SparseMatrix<double>& NetworkHessian::assemble(const Positions& x,
                                                            const ConstraintCurvature& cc) {
  return assemble(x, cc, opt_.project);
}

const Eigen::SparseMatrix<double>& NetworkHessian::assemble(const Positions& x,
                                                            const ConstraintCurvature& cc,
                                                            bool project) {
  constexpr double sqrt3 = 1.73205080756887729353;
  const Network& net = *net_;
  const Topology& t = net.topo;
  const int n = t.num_vertices, ne = t.num_edges(), nf = t.num_faces();
  const bool juelicher = net.bending_model == BendingModel::juelicher && !groups_.empty();
  const bool dihedral = net.bending_model == BendingModel::dihedral && !groups_.empty();
  const double kappa = net.bending.kappa_pNum, h0 = net.bending.h0_per_um;

  // Per edge: link Hessian H_e; Juelicher hinge L theta and its gradient.
  std::vector<Eigen::Matrix3d> link_h(ne);
  std::vector<double> lt(juelicher ? ne : 0);
  std::vector<Eigen::Matrix<double, 3, 4>> lt_grad(juelicher ? ne : 0);
#pragma omp parallel for schedule(static)
  for (int e = 0; e < ne; ++e) {
    const int a = t.edges(0, e), b = t.edges(1, e);
    const Eigen::Vector3d d = x.col(b) - x.col(a);
    const double lbar2 = net.lbar_um(e) * net.lbar_um(e);
    const DensityValue v = evaluate(net.wlc, d.squaredNorm() / lbar2);
    link_h[e] = std::isfinite(v.v)
                    ? Eigen::Matrix3d(sqrt3 * (v.dv * Eigen::Matrix3d::Identity() +
                                               2.0 * v.d2v / lbar2 * d * d.transpose()))
                    : Eigen::Matrix3d::Zero();
    if (juelicher) lt[e] = hinge_length_angle(x, t, e, &lt_grad[e]);
  }
  const bool hinges = juelicher && !hinge_codes_.empty();
  // Per face: area and its gradient.
  std::vector<double> af(nf);
  std::vector<Eigen::Matrix3d> ga(nf);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f)
    af[f] = triangle_area(x.col(t.faces(0, f)), x.col(t.faces(1, f)), x.col(t.faces(2, f)), &ga[f]);
  // Juelicher per vertex: A_v, h_v = (M_v - H0 A_v)/A_v.
  std::vector<double> av(juelicher ? n : 0), hv(juelicher ? n : 0);
  if (juelicher) {
#pragma omp parallel for schedule(static)
    for (int v = 0; v < n; ++v) {
      double m = 0, a = 0;
      for (const int* e = t.vertex_edges.begin(v); e != t.vertex_edges.end(v); ++e) m += lt[*e];
      for (const int* f = t.vertex_faces.begin(v); f != t.vertex_faces.end(v); ++f) a += af[*f];
      av[v] = a / 3.0;
      hv[v] = (0.5 * m - h0 * av[v]) / av[v];
    }
  }
  // Face elements (links split between their two faces), projected.
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    const auto c = t.faces.col(f);
    const Vec3 xa = x.col(c(0)), xb = x.col(c(1)), xc = x.col(c(2));
    const StericDensity s =
        steric_density(net.steric_C_pN_per_um, net.steric, af[f] / net.abar_um2(f));
    double area_coef = s.dv + cc.tension_pN_per_um;
    if (juelicher)
      for (int k = 0; k < 3; ++k)
        area_coef -= kappa * (h0 * hv[c(k)] + 0.5 * hv[c(k)] * hv[c(k)]) / 3.0;
    Eigen::Matrix<double, 9, 1> g;
    for (int k = 0; k < 3; ++k) g.segment<3>(3 * k) = ga[f].col(k);
    FaceMatrix& kf = face_k_[f];
    kf = (s.d2v / net.abar_um2(f)) * g * g.transpose() + area_coef * face_area_hessian(xa, xb, xc) +
         cc.pressure_pN_per_um2 * face_volume_hessian(xa, xb, xc);
    for (int k = 0; k < 3; ++k) {
      const int l = (k + 1) % 3;
      const Eigen::Matrix3d h = 0.5 * link_h[face_edges_[3 * f + k]];
      kf.block<3, 3>(3 * k, 3 * k) += h;
      kf.block<3, 3>(3 * l, 3 * l) += h;
      kf.block<3, 3>(3 * k, 3 * l) -= h;
      kf.block<3, 3>(3 * l, 3 * k) -= h;
    }
    if (project) project_positive_semidefinite<9>(kf);
  }
  if (hinges) {
#pragma omp parallel for schedule(static)
    for (int e = 0; e < ne; ++e) {
      const int a = t.edges(0, e), b = t.edges(1, e);
      hinge_length_angle_second(x.col(a), x.col(b), x.col(t.edge_opposite(0, e)),
                                x.col(t.edge_opposite(1, e)), nullptr, &hinge_k_[e]);
      hinge_k_[e] *= 0.5 * kappa * (hv[a] + hv[b]);
      if (project) project_positive_semidefinite<12>(hinge_k_[e]);
    }
  }
  // Rank-one bending groups: weight w and stacked vector u.
  if (juelicher) {
#pragma omp parallel for schedule(static)
    for (int v = 0; v < n; ++v) {
      const Group& g = groups_[v];
      double* u = group_u_.data() + 3 * g.first;
      std::fill(u, u + 3 * g.size, 0.0);
      const int e0 = t.vertex_edges.offsets[v], f0 = t.vertex_faces.offsets[v];
      for (int k = 0; k < t.vertex_edges.size(v); ++k) {
        const int e = t.vertex_edges.items[e0 + k];
        for (int q = 0; q < 4; ++q)
          Eigen::Map<Eigen::Vector3d>(u + 3 * star_hinge_slots_[4 * (e0 + k) + q]) +=
              0.5 * lt_grad[e].col(q);
      }
      const double c = -(h0 + hv[v]) / 3.0;
      for (int k = 0; k < t.vertex_faces.size(v); ++k) {
        const int f = t.vertex_faces.items[f0 + k];
        for (int q = 0; q < 3; ++q)
          Eigen::Map<Eigen::Vector3d>(u + 3 * star_face_slots_[3 * (f0 + k) + q]) +=
              c * ga[f].col(q);
      }
      group_w_[v] = kappa / av[v];
    }
  } else if (dihedral) {
#pragma omp parallel for schedule(static)
    for (int e = 0; e < ne; ++e) {
      const int* id = group_vertices_.data() + groups_[e].first;
      Eigen::Matrix<double, 3, 4> gt;
      const double theta =
          dihedral_angle(x.col(id[0]), x.col(id[1]), x.col(id[2]), x.col(id[3]), &gt);
      Eigen::Map<Eigen::Matrix<double, 3, 4>>(group_u_.data() + 3 * groups_[e].first) = gt;
      group_w_[e] = net.dihedral_kb_pNum * std::max(std::cos(theta), 0.0);
    }
  }

  // Scatter (serial; every placement is precomputed).
  std::fill(m_.valuePtr(), m_.valuePtr() + m_.nonZeros(), 0.0);
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l <= k; ++l)
        add(face_codes_[9 * f + 3 * k + l], face_k_[f].block<3, 3>(3 * k, 3 * l));
  if (hinges) {
    for (int e = 0; e < ne; ++e) {
      const int id[4] = {t.edges(0, e), t.edges(1, e), t.edge_opposite(0, e),
                         t.edge_opposite(1, e)};
      for (int k = 0; k < 4; ++k)
        for (int l = 0; l <= k; ++l) {
          const Eigen::Matrix3d b = hinge_k_[e].block<3, 3>(3 * k, 3 * l);
          const int code = hinge_codes_[16 * e + 4 * k + l];
          if (code >= 0) {
            add(code, b);
          } else {  // dropped pair (one_ring): [0 B; B^T 0] <= |B| I keeps the bound
            const double norm = b.norm();
            add_diagonal(id[k], norm * Eigen::Matrix3d::Identity());
            add_diagonal(id[l], norm * Eigen::Matrix3d::Identity());
          }
        }
    }
  }
  for (size_t gi = 0; gi < groups_.size(); ++gi) {
    const Group& g = groups_[gi];
    const double w = group_w_[gi];
    if (w == 0.0) continue;
    const double* u = group_u_.data() + 3 * g.first;
    const int* codes = group_codes_.data() + group_code_offsets_[gi];
    for (int k = 0; k < g.size; ++k) {
      const Eigen::Map<const Eigen::Vector3d> uk(u + 3 * k);
      for (int l = 0; l <= k; ++l) {
        const Eigen::Map<const Eigen::Vector3d> ul(u + 3 * l);
        const int code = codes[g.size * k + l];
        if (code >= 0) {
          add(code, w * uk * ul.transpose());
        } else {  // dropped pair: its diagonal bound keeps the sum >= the exact term
          add_diagonal(group_vertices_[g.first + k], w * uk * uk.transpose());
          add_diagonal(group_vertices_[g.first + l], w * ul * ul.transpose());
        }
      }
    }
  }
  double trace = 0.0;
  for (int v = 0; v < n; ++v) {
    const double* d = m_.valuePtr() + block_start_[diagonal_block_[v]];
    const int s = block_stride_[diagonal_block_[v]];
    trace += d[0] + d[s + 1] + d[2 * s + 2];
  }
  const double shift = opt_.shift_fraction * trace / (3.0 * n);
  for (int v = 0; v < n; ++v) {
    double* d = m_.valuePtr() + block_start_[diagonal_block_[v]];
    const int s = block_stride_[diagonal_block_[v]];
    for (int r = 0; r < 3; ++r) d[r * s + r] += shift;
  }
  return m_;
}

}  // namespace rbc
