// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/network_hessian.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/geometry.hpp"
#include "discrete/link_energy.hpp"
#include "discrete/steric_energy.hpp"

namespace rbc {

void NetworkHessianOptions::validate() const {
  if (!(shift_fraction >= 0.0 && shift_fraction < 1.0))
    throw std::invalid_argument("Hessian shift fraction must lie in [0, 1), got " +
                                std::to_string(shift_fraction));
}

namespace {

int find_edge(const Topology& t, int a, int b) {
  for (const int* e = t.vertex_edges.begin(a); e != t.vertex_edges.end(a); ++e)
    if (t.edges(0, *e) == b || t.edges(1, *e) == b) return *e;
  throw std::logic_error("face side is not an edge");  // topology invariant
}

// The bending blocks come from the model's list (model_terms), not from net.bending_model.
bool juelicher_active(const Network& net) {
  return has_term(net, TermKind::juelicher_bending) && net.bending.kappa_pNum > 0;
}
bool dihedral_active(const Network& net) {
  return has_term(net, TermKind::dihedral_bending) && net.dihedral_kb_pNum > 0;
}

/// Lower block pattern: diagonal + edges (+ every pair of a rank-one group for two_ring).
std::vector<std::vector<int>> lower_columns(const Topology& t, bool two_ring,
                                            const std::vector<int>& group_vertices,
                                            const std::vector<int>& group_offsets) {
  std::vector<std::vector<int>> cols(t.num_vertices);
  for (int e = 0; e < t.num_edges(); ++e) {
    const int a = t.edges(0, e), b = t.edges(1, e);
    cols[std::min(a, b)].push_back(std::max(a, b));
  }
  if (two_ring)
    for (size_t g = 0; g + 1 < group_offsets.size(); ++g)
      for (int k = group_offsets[g]; k < group_offsets[g + 1]; ++k)
        for (int l = group_offsets[g]; l < group_offsets[g + 1]; ++l) {
          const int i = group_vertices[k], j = group_vertices[l];
          if (i > j) cols[j].push_back(i);
        }
  return cols;
}

}  // namespace

void NetworkHessian::rebind(const Network& net) {
  const Topology& b = net.topo;
  const bool same_mesh = vertices_ == b.num_vertices && faces_.cols() == b.faces.cols() &&
                         (faces_.array() == b.faces.array()).all();
  if (!same_mesh)
    throw std::invalid_argument("network Hessian: rebinding to another mesh (" +
                                std::to_string(b.num_vertices) + " vertices, expected " +
                                std::to_string(vertices_) + " and the same faces)");
  for (TermKind k : {TermKind::in_plane, TermKind::area_volume})
    if (!has_term(net, k))
      throw std::invalid_argument(
          "network Hessian: rebinding to a model without the " +
          std::string(k == TermKind::in_plane ? "in-plane" : "area/volume") + " term");
  if (juelicher_active(net) != juelicher_ || dihedral_active(net) != dihedral_)
    throw std::invalid_argument("network Hessian: rebinding to another bending law");
  bool custom = !custom_.empty();
  for (const NetworkTerm& term : model_terms(net)) custom = custom || term.kind == TermKind::custom;
  if (custom)
    throw std::invalid_argument("network Hessian: models with custom terms cannot be rebound");
  net_ = &net;
}

NetworkHessian::NetworkHessian(const Network& net, const NetworkHessianOptions& options)
    : net_(&net),
      vertices_(net.topo.num_vertices),
      faces_(net.topo.faces),
      opt_((options.validate(), options)),
      m_({}, BlockStorage::lower) {
  const Topology& t = net.topo;
  for (TermKind k : {TermKind::in_plane, TermKind::area_volume})
    if (!has_term(net, k))
      throw std::invalid_argument(
          "the Newton preconditioner needs the in-plane and area/volume terms; the model's list "
          "lacks the " +
          std::string(k == TermKind::in_plane ? "in-plane" : "area/volume") + " term");
  const bool juelicher = juelicher_active(net), dihedral = dihedral_active(net);
  juelicher_ = juelicher;
  dihedral_ = dihedral;
  // Custom terms' pieces (LocalPieces::hessian): every vertex pair of a piece is coupled.
  for (const NetworkTerm& term : model_terms(net))
    if (term.kind == TermKind::custom && term.pieces.layout && term.pieces.hessian)
      custom_.push_back({&term, term.pieces.layout(net), {}, {}});

  // Rank-one groups: Juelicher vertex stars or Kantor-Nelson hinges.
  std::vector<int> offsets(1, 0);
  if (juelicher) {
    stars_ = make_vertex_stars(t);
    group_vertices_ = stars_.vertices;
    offsets = stars_.offsets;
  } else if (dihedral) {
    for (int e = 0; e < t.num_edges(); ++e) {
      for (int id : {t.edges(0, e), t.edges(1, e), t.edge_opposite(0, e), t.edge_opposite(1, e)})
        group_vertices_.push_back(id);
      offsets.push_back(static_cast<int>(group_vertices_.size()));
    }
  }
  for (size_t g = 0; g + 1 < offsets.size(); ++g)
    groups_.push_back({offsets[g], offsets[g + 1] - offsets[g]});
  std::vector<std::vector<int>> columns = lower_columns(
      t, opt_.bending_coupling == BendingCoupling::two_ring, group_vertices_, offsets);
  for (const CustomTerm& c : custom_)
    for (int p = 0; p < c.layout.count(); ++p)
      for (int k = c.layout.offsets[p]; k < c.layout.offsets[p + 1]; ++k)
        for (int l = c.layout.offsets[p]; l < c.layout.offsets[p + 1]; ++l) {
          const int i = c.layout.vertices[k], j = c.layout.vertices[l];
          if (i > j) columns[j].push_back(i);
        }
  m_ = BlockMatrix(std::move(columns), BlockStorage::lower);
  for (CustomTerm& c : custom_) {
    for (int p = 0; p < c.layout.count(); ++p)
      for (int k = c.layout.offsets[p]; k < c.layout.offsets[p + 1]; ++k)
        for (int l = c.layout.offsets[p]; l < c.layout.offsets[p + 1]; ++l)
          c.codes.push_back(m_.block_code(c.layout.vertices[k], c.layout.vertices[l]));
    c.matrices.resize(c.layout.count());
  }

  // Element placements.
  face_edges_.resize(3 * static_cast<size_t>(t.num_faces()));
  face_codes_.resize(9 * static_cast<size_t>(t.num_faces()));
  for (int f = 0; f < t.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      face_edges_[3 * f + k] = find_edge(t, t.faces(k, f), t.faces((k + 1) % 3, f));
      for (int l = 0; l < 3; ++l)
        face_codes_[9 * f + 3 * k + l] = m_.block_code(t.faces(k, f), t.faces(l, f));
    }
  }
  group_code_offsets_.assign(groups_.size() + 1, 0);
  for (size_t g = 0; g < groups_.size(); ++g) {
    const Group& gr = groups_[g];
    for (int k = 0; k < gr.size; ++k)
      for (int l = 0; l < gr.size; ++l)
        group_codes_.push_back(
            m_.block_code(group_vertices_[gr.first + k], group_vertices_[gr.first + l]));
    group_code_offsets_[g + 1] = static_cast<int>(group_codes_.size());
  }
  if (juelicher && opt_.hinge_curvature) prepare_hinges();
  face_k_.resize(t.num_faces());
  group_u_.resize(3 * group_vertices_.size());
  group_w_.resize(groups_.size());
}

void NetworkHessian::prepare_hinges() {
  if (!hinge_codes_.empty()) return;
  const Topology& t = net_->topo;
  hinge_codes_.resize(16 * static_cast<size_t>(t.num_edges()));
  for (int e = 0; e < t.num_edges(); ++e) {
    const int id[4] = {t.edges(0, e), t.edges(1, e), t.edge_opposite(0, e), t.edge_opposite(1, e)};
    for (int k = 0; k < 4; ++k)
      for (int l = 0; l < 4; ++l) hinge_codes_[16 * e + 4 * k + l] = m_.block_code(id[k], id[l]);
  }
  hinge_k_.resize(t.num_edges());
}

const Eigen::SparseMatrix<double>& NetworkHessian::assemble(const Positions& x,
                                                            const ConstraintCurvature& cc) {
  return assemble(x, cc, opt_.project);
}

const Eigen::SparseMatrix<double>& NetworkHessian::assemble(const Positions& x,
                                                            const ConstraintCurvature& cc,
                                                            bool project) {
  return assemble_terms(x, cc, project, opt_.hinge_curvature, -1.0);
}

const Eigen::SparseMatrix<double>& NetworkHessian::assemble_exact(const Positions& x,
                                                                  const ConstraintCurvature& cc,
                                                                  double diagonal_shift) {
  if (opt_.bending_coupling != BendingCoupling::two_ring)
    throw std::logic_error("the exact network Hessian needs the two-ring pattern");
  if (juelicher_) prepare_hinges();
  return assemble_terms(x, cc, false, true, diagonal_shift);
}

const Eigen::SparseMatrix<double>& NetworkHessian::assemble_terms(const Positions& x,
                                                                  const ConstraintCurvature& cc,
                                                                  bool project, bool hinge_term,
                                                                  double shift) {
  const Network& net = *net_;
  const Topology& t = net.topo;
  const int n = t.num_vertices, ne = t.num_edges(), nf = t.num_faces();
  const bool juelicher = juelicher_ && !groups_.empty();
  const bool dihedral = dihedral_ && !groups_.empty();

  // Per edge: the link term's exact Hessian H_e (zero outside its domain).
  std::vector<Eigen::Matrix3d> link_h(ne);
#pragma omp parallel for schedule(static)
  for (int e = 0; e < ne; ++e) {
    link_h[e].setZero();
    link_energy(net.wlc, net.lbar_um(e), x.col(t.edges(0, e)), x.col(t.edges(1, e)), nullptr,
                &link_h[e]);
  }
  // Juelicher: the cells and the element derivatives, from the bending term itself.
  const JuelicherHessianTerms bend =
      juelicher ? juelicher_hessian_terms(x, t, net.bending) : JuelicherHessianTerms{};
  const bool hinges = juelicher && hinge_term && !hinge_codes_.empty();
  // Face elements (links split between their two faces), projected.
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    const auto c = t.faces.col(f);
    const Vec3 xa = x.col(c(0)), xb = x.col(c(1)), xc = x.col(c(2));
    Eigen::Matrix3d ga;
    const double area = triangle_area(xa, xb, xc, &ga);
    Vector9d g;
    for (int k = 0; k < 3; ++k) g.segment<3>(3 * k) = ga.col(k);
    Matrix9d d2a;
    triangle_area_hessian(xa, xb, xc, nullptr, &d2a);
    // Steric s'(J), the constraint tension and Juelicher's beta_f share d2A.
    const auto area_coef = [&](double ds) {
      const double c = ds + cc.tension_pN_per_um;
      return juelicher ? bend.add_face_coef(t, f, c) : c;
    };
    Matrix9d& kf = face_k_[f];
    steric_face_terms<9>(net.steric_C_pN_per_um, net.steric, net.abar_um2(f), area, g, &d2a,
                         nullptr, &kf, area_coef);
    kf += cc.pressure_pN_per_um2 * tetra_volume_hessian(xa, xb, xc);
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
      hinge_length_angle_hessian(x.col(t.edges(0, e)), x.col(t.edges(1, e)),
                                 x.col(t.edge_opposite(0, e)), x.col(t.edge_opposite(1, e)),
                                 nullptr, &hinge_k_[e]);
      hinge_k_[e] *= bend.hinge_coef(t, e);
      if (project) project_positive_semidefinite<12>(hinge_k_[e]);
    }
  }
  // Rank-one bending groups: weight w and stacked vector u.
  if (juelicher) {
#pragma omp parallel for schedule(static)
    for (int v = 0; v < n; ++v) {
      bend.cell_gradient(t, stars_, v, group_u_.data() + 3 * groups_[v].first);
      group_w_[v] = bend.cell_weight(v);
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
  m_.set_zero();
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l <= k; ++l)
        m_.add(face_codes_[9 * f + 3 * k + l], face_k_[f].block<3, 3>(3 * k, 3 * l));
  if (hinges) {
    for (int e = 0; e < ne; ++e) {
      const int id[4] = {t.edges(0, e), t.edges(1, e), t.edge_opposite(0, e),
                         t.edge_opposite(1, e)};
      for (int k = 0; k < 4; ++k)
        for (int l = 0; l <= k; ++l) {
          const Eigen::Matrix3d b = hinge_k_[e].block<3, 3>(3 * k, 3 * l);
          const int code = hinge_codes_[16 * e + 4 * k + l];
          if (code >= 0) {
            m_.add(code, b);
          } else {  // dropped pair (one_ring): [0 B; B^T 0] <= |B| I keeps the bound
            const double norm = b.norm();
            m_.add_diagonal(id[k], norm * Eigen::Matrix3d::Identity());
            m_.add_diagonal(id[l], norm * Eigen::Matrix3d::Identity());
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
          m_.add(code, w * uk * ul.transpose());
        } else {  // dropped pair: its diagonal bound keeps the sum >= the exact term
          m_.add_diagonal(group_vertices_[g.first + k], w * uk * uk.transpose());
          m_.add_diagonal(group_vertices_[g.first + l], w * ul * ul.transpose());
        }
      }
    }
  }
  // Custom terms: each piece's own Hessian (projected when `project`), in list order.
  for (CustomTerm& c : custom_) {
    const int np = c.layout.count();
#pragma omp parallel for schedule(static)
    for (int p = 0; p < np; ++p) {
      c.matrices[p] = c.term->pieces.hessian(net, x, p);
      if (project) project_positive_semidefinite<Eigen::Dynamic>(c.matrices[p]);
    }
    const int* code = c.codes.data();
    for (int p = 0; p < np; ++p) {
      const int size = c.layout.offsets[p + 1] - c.layout.offsets[p];
      for (int k = 0; k < size; ++k)
        for (int l = 0; l <= k; ++l)
          m_.add(code[size * k + l], c.matrices[p].block<3, 3>(3 * k, 3 * l));
      code += size * size;
    }
  }
  // shift < 0: the options' fraction of the mean diagonal.
  m_.shift_diagonal(shift >= 0 ? shift : opt_.shift_fraction * m_.trace() / (3.0 * n));
  return m_.matrix();
}

}  // namespace rbc
