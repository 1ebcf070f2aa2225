// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/loop_stretch.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "continuum/loop_bending.hpp"
#include "core/validation.hpp"

namespace rbc {

namespace loop_stretch_internal {

// Rest limit-surface position and tangents at a basis.
Vec3 rest_point(const LoopBasis& b, const Positions& x, int row) {
  Vec3 p = Vec3::Zero();
  for (std::size_t k = 0; k < b.vertices.size(); ++k)
    p += b.shape(row, static_cast<Eigen::Index>(k)) * x.col(b.vertices[k]);
  return p;
}

// The 16 centroids of face's two-level 1-to-4 split, in (v, w), each of parameter area 1/32.
std::vector<Eigen::Vector2d> sub_centroids() {
  std::vector<Eigen::Vector2d> pts;
  const int n = 4;  // 4 x 4 grid of the reference triangle: n^2 = 16 small triangles
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n - i; ++j) {
      pts.emplace_back((i + 1.0 / 3) / n, (j + 1.0 / 3) / n);  // upright triangle
      if (i + j < n - 1) pts.emplace_back((i + 2.0 / 3) / n, (j + 2.0 / 3) / n);  // inverted
    }
  return pts;
}

}  // namespace loop_stretch_internal

LoopContinuumModel build_loop_continuum_model(const TriMesh& rest_on_surface,
                                              const IsotropicMembraneLaw& law,
                                              const BendingParameters& bending,
                                              double contact_plane_um) {
  namespace lsi = loop_stretch_internal;
  if (!law.evaluate)
    throw InvalidParameter("Loop continuum law", "empty", "an in-plane membrane law");
  bending.validate();
  require_finite_in_range("contact plane", "um", contact_plane_um, 0.0, kUnbounded,
                          Ends::open_open);
  LoopContinuumModel m;
  m.topo = rest_on_surface.topo;
  m.rest = loop_interpolating_control_points(m.topo, rest_on_surface.x);
  m.quadrature = loop_quadrature(m.topo);
  m.law = law;
  m.bending = bending;
  m.reference.reserve(m.quadrature.size());
  for (const LoopQuadraturePoint& q : m.quadrature)
    m.reference.push_back(make_loop_membrane_reference(lsi::rest_point(q.basis, m.rest, 1),
                                                       lsi::rest_point(q.basis, m.rest, 2)));
  const ConstraintValues c = loop_constraints(m, m.rest, false);
  m.area0_um2 = c.area_um2;
  m.volume0_um3 = c.volume_um3;

  // Load: the cap's points with their rest area weights, per cap, then normalised.
  const int n = m.topo.num_vertices;
  Eigen::VectorXd right = Eigen::VectorXd::Zero(3 * n), left = Eigen::VectorXd::Zero(3 * n);
  double right_area = 0, left_area = 0;
  LoopSubdivision sub(m.topo, 4);
  const std::vector<Eigen::Vector2d> fine = lsi::sub_centroids();
  auto add = [&](const LoopBasis& b, double weight) {
    const Vec3 p = lsi::rest_point(b, m.rest, 0);
    if (std::abs(p.x()) < contact_plane_um) return;
    const double a =
        weight * lsi::rest_point(b, m.rest, 1).cross(lsi::rest_point(b, m.rest, 2)).norm();
    Eigen::VectorXd& l = p.x() > 0 ? right : left;
    (p.x() > 0 ? right_area : left_area) += a;
    for (std::size_t k = 0; k < b.vertices.size(); ++k)
      l(3 * b.vertices[k]) += a * b.shape(0, static_cast<Eigen::Index>(k));
    ++m.load_points;
  };
  for (int f = 0; f < m.topo.num_faces(); ++f) {
    double reach = 0, edge = 0;
    for (int k = 0; k < 3; ++k) {
      const Vec3 a = rest_on_surface.x.col(m.topo.faces(k, f)),
                 b = rest_on_surface.x.col(m.topo.faces((k + 1) % 3, f));
      reach = std::max(reach, std::abs(a.x()));
      edge = std::max(edge, (a - b).norm());
    }
    if (reach < contact_plane_um - edge) continue;  // no part of the face near the caps
    bool inside = true;
    for (int k = 0; k < 3; ++k)
      inside =
          inside && std::abs(rest_on_surface.x(0, m.topo.faces(k, f))) > contact_plane_um + edge;
    if (inside) {
      for (int qi = 3 * f; qi < 3 * f + 3; ++qi)
        add(m.quadrature[qi].basis, m.quadrature[qi].weight);
    } else {
      for (const Eigen::Vector2d& p : fine) add(sub.basis(f, p(0), p(1)), 1.0 / 32.0);
    }
  }
  if (!(right_area > 0 && left_area > 0))
    throw InvalidParameter("contact plane", format_number(contact_plane_um),
                           "a plane that cuts a cap off each end of the rest surface", "um");
  m.load_right = right / right_area;
  m.load_left = left / left_area;
  m.load = m.load_right - m.load_left;
  m.measure_sampling = loop_limit_sampling_matrix(m.topo, 3);
  return m;
}

double loop_continuum_energy(const LoopContinuumModel& m, const Positions& x, double force_pN,
                             Positions* grad) {
  double energy = 0;
  Vector6d gm;
  Eigen::VectorXd g6(6), g15(15);
  LoopJetGradient gb;
  if (grad != nullptr) grad->setZero(3, x.cols());
  for (std::size_t i = 0; i < m.quadrature.size(); ++i) {
    const LoopQuadraturePoint& q = m.quadrature[i];
    const LoopJet jet = loop_jet(q.basis, x);
    const double em = loop_membrane_density(m.law, m.reference[i], jet[0], jet[1],
                                            grad != nullptr ? &gm : nullptr);
    if (!std::isfinite(em)) return std::numeric_limits<double>::infinity();
    const double eb = loop_helfrich_density(m.bending, jet, grad != nullptr ? &gb : nullptr);
    if (!std::isfinite(eb)) return std::numeric_limits<double>::infinity();
    energy += q.weight * (em + eb);
    if (grad != nullptr) {
      g6 = q.weight * gm;
      g15 = q.weight * gb;
      add_loop_point_derivatives(q.basis, 1, 2, g6, nullptr, grad, nullptr);
      add_loop_point_derivatives(q.basis, 1, 5, g15, nullptr, grad, nullptr);
    }
  }
  const Eigen::Map<const Eigen::VectorXd> xf(x.data(), x.size()), rf(m.rest.data(), m.rest.size());
  energy -= force_pN * m.load.dot(xf - rf);
  if (grad != nullptr) flat(*grad) -= force_pN * m.load;
  return energy;
}

ConstraintValues loop_constraints(const LoopContinuumModel& m, const Positions& x, bool gradients) {
  ConstraintValues c;
  if (gradients) {
    c.grad_area.setZero(3, x.cols());
    c.grad_volume.setZero(3, x.cols());
  }
  Vector6d ga;
  Vector9d gv;
  Eigen::VectorXd g6(6), g9(9);
  for (const LoopQuadraturePoint& q : m.quadrature) {
    Vec3 p = Vec3::Zero(), xv = Vec3::Zero(), xw = Vec3::Zero();
    for (std::size_t k = 0; k < q.basis.vertices.size(); ++k) {
      const Vec3 xk = x.col(q.basis.vertices[k]);
      p += q.basis.shape(0, static_cast<Eigen::Index>(k)) * xk;
      xv += q.basis.shape(1, static_cast<Eigen::Index>(k)) * xk;
      xw += q.basis.shape(2, static_cast<Eigen::Index>(k)) * xk;
    }
    c.area_um2 += q.weight * loop_area_density(xv, xw, gradients ? &ga : nullptr);
    c.volume_um3 += q.weight * loop_volume_density(p, xv, xw, gradients ? &gv : nullptr);
    if (gradients) {
      g6 = q.weight * ga;
      g9 = q.weight * gv;
      add_loop_point_derivatives(q.basis, 1, 2, g6, nullptr, &c.grad_area, nullptr);
      add_loop_point_derivatives(q.basis, 0, 3, g9, nullptr, &c.grad_volume, nullptr);
    }
  }
  return c;
}

namespace loop_stretch_internal {

std::vector<std::vector<int>> block_columns(const LoopContinuumModel& m) {
  std::vector<std::vector<int>> cols(m.topo.num_vertices);
  for (const LoopQuadraturePoint& q : m.quadrature)
    for (int a : q.basis.vertices)
      for (int b : q.basis.vertices)
        if (a >= b) cols[b].push_back(a);
  return cols;
}

}  // namespace loop_stretch_internal

LoopHessianAssembler::LoopHessianAssembler(const LoopContinuumModel& model)
    : matrix_(loop_stretch_internal::block_columns(model), BlockStorage::lower) {
  code_offsets_.reserve(model.quadrature.size() + 1);
  code_offsets_.push_back(0);
  for (const LoopQuadraturePoint& q : model.quadrature) {
    for (int a : q.basis.vertices)
      for (int b : q.basis.vertices) codes_.push_back(a >= b ? matrix_.block_code(a, b) : -1);
    code_offsets_.push_back(static_cast<int>(codes_.size()));
  }
}

const Eigen::SparseMatrix<double>& LoopHessianAssembler::assemble(const LoopContinuumModel& m,
                                                                  const Positions& x,
                                                                  double area_coef,
                                                                  double volume_coef) {
  matrix_.set_zero();
  Vector6d g6;
  Matrix6d hm, ha;
  Eigen::Matrix<double, 9, 9> hv;
  LoopJetGradient gb;
  LoopJetHessian hb;
  // The point's Hessian in its jet rows 0-5 (position, tangents, second derivatives): bending
  // on rows 1-5, membrane and area on 1-2, volume on 0-2.
  Eigen::Matrix<double, 18, 18> h;
  Eigen::Matrix<double, 3, 18> t;
  for (std::size_t i = 0; i < m.quadrature.size(); ++i) {
    const LoopQuadraturePoint& q = m.quadrature[i];
    const LoopJet jet = loop_jet(q.basis, x);
    Vec3 p = Vec3::Zero();
    const int ns = static_cast<int>(q.basis.vertices.size());
    for (int k = 0; k < ns; ++k) p += q.basis.shape(0, k) * x.col(q.basis.vertices[k]);
    if (!std::isfinite(loop_membrane_density(m.law, m.reference[i], jet[0], jet[1], &g6, &hm)))
      hm.setZero();
    loop_area_density(jet[0], jet[1], nullptr, &ha);
    loop_volume_density(p, jet[0], jet[1], nullptr, &hv);
    if (!std::isfinite(loop_helfrich_density(m.bending, jet, &gb, &hb))) hb.setZero();
    h.setZero();
    h.block<15, 15>(3, 3) = hb;
    h.block<9, 9>(0, 0) += volume_coef * hv;
    h.block<6, 6>(3, 3) += hm + area_coef * ha;
    h *= q.weight;
    // Block (k, l) = sum_rs S(r, k) S(s, l) h_rs: first t = sum_r S(r, k) h_r. (3 x 18), then
    // the block for each l.
    const int* codes = codes_.data() + code_offsets_[i];
    for (int k = 0; k < ns; ++k) {
      t.setZero();
      for (int r = 0; r < 6; ++r) t += q.basis.shape(r, k) * h.block<3, 18>(3 * r, 0);
      for (int l = 0; l < ns; ++l) {
        const int code = codes[k * ns + l];
        if (code < 0) continue;
        Eigen::Matrix3d b = Eigen::Matrix3d::Zero();
        for (int s = 0; s < 6; ++s) b += q.basis.shape(s, l) * t.block<3, 3>(0, 3 * s);
        matrix_.add(code, b);
      }
    }
  }
  return matrix_.matrix();
}

Diameters loop_surface_diameters(const LoopContinuumModel& model, const Positions& x) {
  return measure_diameters((model.measure_sampling * x.transpose()).transpose());
}

std::vector<LoopStretchPoint> run_loop_stretch(const LoopContinuumModel& model,
                                               const std::vector<double>& forces_pN,
                                               const LoopStretchOptions& options) {
  options.newton.validate();
  require_integer_in_range("force bisections", options.max_bisections, 0, 30);
  for (double f : forces_pN)
    require_finite_in_range("force", "pN", f, 0.0, kUnbounded, Ends::closed_open);
  const Eigen::Index n = model.rest.cols();
  ShiftedNewton newton(options.newton);
  LoopHessianAssembler assembler(model);
  double force = 0;
  NewtonProblem pb;
  pb.evaluate = [&](const Eigen::VectorXd& xf, NewtonPoint& p) {
    const Eigen::Map<const Positions> x(xf.data(), 3, n);
    Positions g;
    p.value = loop_continuum_energy(model, x, force, &g);
    if (!std::isfinite(p.value)) return false;
    p.grad = flat(g);
    const ConstraintValues c = loop_constraints(model, x, true);
    p.c.resize(2);
    p.c << c.area_um2 - model.area0_um2, c.volume_um3 - model.volume0_um3;
    p.c_grad.resize(3 * n, 2);
    p.c_grad.col(0) = flat(c.grad_area);
    p.c_grad.col(1) = flat(c.grad_volume);
    return true;
  };
  pb.hessian = [&](const Eigen::VectorXd& xf,
                   const Eigen::VectorXd& lambda) -> const Eigen::SparseMatrix<double>& {
    return assembler.assemble(model, Eigen::Map<const Positions>(xf.data(), 3, n), lambda(0),
                              lambda(1));
  };
  pb.constraint_scale = Eigen::Vector2d(model.area0_um2, model.volume0_um3);

  std::vector<LoopStretchPoint> out;
  Eigen::VectorXd x = flat(model.rest), lambda = Eigen::VectorXd::Zero(2);
  double done = 0;
  for (double target : forces_pN) {
    LoopStretchPoint pt;
    pt.force_pN = target;
    Eigen::VectorXd xs = x, ls = lambda;
    double from = done;
    double step = target - from;
    int halvings = 0;
    ShiftedNewtonResult r;
    while (true) {
      force = from + step;
      Eigen::VectorXd xt = xs, lt = ls;
      r = newton.solve(pb, xt, lt);
      pt.iterations += r.iterations;
      pt.factorisations += r.factorisations;
      if (r.status == NewtonStatus::converged) {
        xs = xt;
        ls = lt;
        from = force;
        if (from == target) break;
        step = target - from;
        continue;
      }
      if (++halvings > options.max_bisections) break;
      step *= 0.5;
    }
    pt.status = r.status;
    pt.residual_pN = r.residual;
    if (r.status == NewtonStatus::converged) {
      x = xs;
      lambda = ls;
      done = target;
    }
    pt.x = Eigen::Map<const Positions>(xs.data(), 3, n);
    pt.diameters = loop_surface_diameters(model, pt.x);
    out.push_back(std::move(pt));
  }
  return out;
}

}  // namespace rbc
