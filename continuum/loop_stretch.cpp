// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/loop_stretch.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "continuum/loop_bending.hpp"
#include "core/reduced_problem.hpp"
#include "core/symmetry_stability.hpp"
#include "core/validation.hpp"

namespace rbc {

namespace loop_stretch_internal {

// The bead load's x entries are cap fractions of order 1/(the cap's control points), normalised
// by their largest here: differences below this are round-off.
constexpr double kLoadShareTolerance = 1e-12;

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
  m.cap_right_um2 = right_area;
  m.cap_left_um2 = left_area;
  m.load_right = right / right_area;
  m.load_left = left / left_area;
  m.load = m.load_right - m.load_left;
  m.measure_sampling = loop_limit_sampling_matrix(m.topo, 3);
  m.vertex_sampling = loop_limit_sampling_matrix(m.topo, 0);
  return m;
}

LoopPointSet loop_all_points(const LoopContinuumModel& m) {
  LoopPointSet s;
  s.points.resize(m.quadrature.size());
  for (std::size_t i = 0; i < s.points.size(); ++i) s.points[i] = static_cast<int>(i);
  s.multiplicity.assign(s.points.size(), 1.0);
  return s;
}

LoopPointSet loop_orbit_points(const LoopContinuumModel& m, const MeshSymmetry& symmetry) {
  const int faces = m.topo.num_faces();
  if (m.quadrature.size() != static_cast<std::size_t>(3 * faces))
    throw std::invalid_argument("loop_orbit_points: not loop_quadrature's three points a face");
  // A point's corner: the face vertex it lies nearest (the rule's points are (2/3, 1/6, 1/6)
  // and its permutations in barycentric coordinates).
  auto corner = [&](int i) {
    const LoopQuadraturePoint& q = m.quadrature[static_cast<std::size_t>(i)];
    if (q.face != i / 3)
      throw std::invalid_argument("loop_orbit_points: the quadrature is not face-major");
    return q.v > 0.5 ? 1 : q.w > 0.5 ? 2 : 0;
  };
  std::map<std::array<int, 3>, int> face_of;
  for (int f = 0; f < faces; ++f) {
    std::array<int, 3> key{m.topo.faces(0, f), m.topo.faces(1, f), m.topo.faces(2, f)};
    std::sort(key.begin(), key.end());
    face_of[key] = f;
  }
  const int n = static_cast<int>(m.quadrature.size());
  std::vector<int> rep(static_cast<std::size_t>(n), -1);
  LoopPointSet s;
  for (int i = 0; i < n; ++i) {
    if (rep[static_cast<std::size_t>(i)] >= 0) continue;
    const int f = i / 3, v = m.topo.faces(corner(i), f);
    std::vector<int> orbit;
    for (int g = 0; g < symmetry.order(); ++g) {
      const auto& image = symmetry.image[static_cast<std::size_t>(g)];
      if (image.size() != static_cast<std::size_t>(m.topo.num_vertices))
        throw std::invalid_argument("loop_orbit_points: a symmetry of another mesh");
      std::array<int, 3> key{};
      for (int k = 0; k < 3; ++k) key[k] = image[static_cast<std::size_t>(m.topo.faces(k, f))];
      std::sort(key.begin(), key.end());
      const auto it = face_of.find(key);
      if (it == face_of.end())
        throw std::invalid_argument("loop_orbit_points: a face's mirror image is not a face");
      const int gv = image[static_cast<std::size_t>(v)];
      int j = -1;
      for (int k = 0; k < 3; ++k)
        if (m.topo.faces(corner(3 * it->second + k), it->second) == gv) j = 3 * it->second + k;
      if (j < 0) throw std::invalid_argument("loop_orbit_points: no image point");
      if (std::find(orbit.begin(), orbit.end(), j) == orbit.end()) orbit.push_back(j);
    }
    for (int j : orbit) rep[static_cast<std::size_t>(j)] = i;
    s.points.push_back(i);
    s.multiplicity.push_back(static_cast<double>(orbit.size()));
  }
  return s;
}

namespace loop_stretch_internal {

// A point's limit position and derivatives d[0..5] (rows 0-5 of its basis: position, tangents,
// second derivatives; um) in one pass over its support, and its jet (d[1..5]).
LoopJet position_and_jet(const LoopBasis& b, const Positions& x, Vec3 (&d)[6]) {
  for (Vec3& r : d) r.setZero();
  for (std::size_t k = 0; k < b.vertices.size(); ++k) {
    const Vec3 xk = x.col(b.vertices[k]);
    for (int r = 0; r < 6; ++r) d[r] += b.shape(r, static_cast<Eigen::Index>(k)) * xk;
  }
  return {d[1], d[2], d[3], d[4], d[5]};
}

// One pass over the points: the energy's terms (with_energy; their gradient into grad) and the
// constraints (c; their gradients when grad is given), the position and jet formed once a point.
double evaluate_pass(const LoopContinuumModel& m, const LoopPointSet& set, const Positions& x,
                     double force_pN, bool with_energy, Positions* grad, ConstraintValues* c) {
  double energy = 0;
  Vector6d gm, ga;
  Vector9d gv;
  LoopJetGradient gb;
  Eigen::Matrix<double, 18, 1> ge;
  const bool gradients = grad != nullptr;
  bool infinite = !with_energy;  // no energy wanted: as past an infinite term
  if (gradients) grad->setZero(3, x.cols());
  if (c != nullptr) {
    *c = ConstraintValues{};
    if (gradients) {
      c->grad_area.setZero(3, x.cols());
      c->grad_volume.setZero(3, x.cols());
    }
  }
  for (std::size_t e = 0; e < set.points.size(); ++e) {
    const std::size_t i = static_cast<std::size_t>(set.points[e]);
    const LoopQuadraturePoint& q = m.quadrature[i];
    const LoopBasis& b = q.basis;
    const int ns = static_cast<int>(b.vertices.size());
    Vec3 d[6];
    const LoopJet jet = position_and_jet(b, x, d);
    const double w = q.weight * set.multiplicity[e];
    if (!infinite) {
      const double em =
          loop_membrane_density(m.law, m.reference[i], d[1], d[2], gradients ? &gm : nullptr);
      const double eb =
          std::isfinite(em) ? loop_helfrich_density(m.bending, jet, gradients ? &gb : nullptr) : em;
      infinite = !std::isfinite(eb);
      // Past an infinite term only the constraints are still wanted.
      if (infinite && c == nullptr) break;
      energy += w * (em + eb);
    }
    if (c != nullptr) {
      c->area_um2 += w * loop_area_density(d[1], d[2], gradients ? &ga : nullptr);
      c->volume_um3 += w * loop_volume_density(d[0], d[1], d[2], gradients ? &gv : nullptr);
    }
    if (!gradients) continue;
    if (!infinite) {
      ge.setZero();
      ge.segment<15>(3) = gb;
      ge.segment<6>(3) += gm;
      ge *= w;
    }
    for (int k = 0; k < ns; ++k) {
      auto gk = grad->col(b.vertices[static_cast<std::size_t>(k)]);
      if (!infinite)
        for (int r = 1; r < 6; ++r) gk += b.shape(r, k) * ge.segment<3>(3 * r);
      if (c == nullptr) continue;
      auto ak = c->grad_area.col(b.vertices[static_cast<std::size_t>(k)]);
      auto vk = c->grad_volume.col(b.vertices[static_cast<std::size_t>(k)]);
      for (int r = 0; r < 3; ++r) {
        if (r > 0) ak += (w * b.shape(r, k)) * ga.segment<3>(3 * (r - 1));
        vk += (w * b.shape(r, k)) * gv.segment<3>(3 * r);
      }
    }
  }
  if (!with_energy) return 0.0;
  if (infinite) return std::numeric_limits<double>::infinity();
  const Eigen::Map<const Eigen::VectorXd> xf(x.data(), x.size()), rf(m.rest.data(), m.rest.size());
  energy -= force_pN * m.load.dot(xf - rf);
  if (gradients) flat(*grad) -= force_pN * m.load;
  return energy;
}

}  // namespace loop_stretch_internal

double loop_evaluate(const LoopContinuumModel& m, const LoopPointSet& set, const Positions& x,
                     double force_pN, Positions* grad, ConstraintValues* c) {
  return loop_stretch_internal::evaluate_pass(m, set, x, force_pN, true, grad, c);
}

double loop_continuum_energy(const LoopContinuumModel& m, const Positions& x, double force_pN,
                             Positions* grad) {
  return loop_evaluate(m, loop_all_points(m), x, force_pN, grad, nullptr);
}

ConstraintValues loop_constraints(const LoopContinuumModel& m, const Positions& x, bool gradients) {
  ConstraintValues c;
  Positions g;
  loop_stretch_internal::evaluate_pass(m, loop_all_points(m), x, 0.0, false,
                                       gradients ? &g : nullptr, &c);
  return c;
}

namespace loop_stretch_internal {

std::vector<std::vector<int>> block_columns(const LoopContinuumModel& m, const LoopPointSet& set) {
  std::vector<std::vector<int>> cols(static_cast<std::size_t>(m.topo.num_vertices));
  for (int i : set.points)
    for (int a : m.quadrature[static_cast<std::size_t>(i)].basis.vertices)
      for (int b : m.quadrature[static_cast<std::size_t>(i)].basis.vertices)
        if (a >= b) cols[static_cast<std::size_t>(b)].push_back(a);
  return cols;
}

}  // namespace loop_stretch_internal

LoopHessianAssembler::LoopHessianAssembler(const LoopContinuumModel& model)
    : LoopHessianAssembler(model, loop_all_points(model)) {}

LoopHessianAssembler::LoopHessianAssembler(const LoopContinuumModel& model, LoopPointSet set)
    : set_(std::move(set)),
      matrix_(loop_stretch_internal::block_columns(model, set_), BlockStorage::lower) {
  code_offsets_.reserve(set_.points.size() + 1);
  code_offsets_.push_back(0);
  for (int i : set_.points) {
    const LoopBasis& b = model.quadrature[static_cast<std::size_t>(i)].basis;
    for (int a : b.vertices)
      for (int c : b.vertices) codes_.push_back(a >= c ? matrix_.block_code(a, c) : -1);
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
  for (std::size_t e = 0; e < set_.points.size(); ++e) {
    const std::size_t i = static_cast<std::size_t>(set_.points[e]);
    const LoopQuadraturePoint& q = m.quadrature[i];
    const LoopBasis& b = q.basis;
    const int ns = static_cast<int>(b.vertices.size());
    Vec3 d[6];
    const LoopJet jet = loop_stretch_internal::position_and_jet(b, x, d);
    if (!std::isfinite(loop_membrane_density(m.law, m.reference[i], d[1], d[2], &g6, &hm)))
      hm.setZero();
    loop_area_density(d[1], d[2], nullptr, &ha);
    loop_volume_density(d[0], d[1], d[2], nullptr, &hv);
    if (!std::isfinite(loop_helfrich_density(m.bending, jet, &gb, &hb))) hb.setZero();
    h.setZero();
    h.block<15, 15>(3, 3) = hb;
    h.block<9, 9>(0, 0) += volume_coef * hv;
    h.block<6, 6>(3, 3) += hm + area_coef * ha;
    h *= q.weight * set_.multiplicity[e];
    // Block (k, l) = sum_rs S(r, k) S(s, l) h_rs: first t = sum_r S(r, k) h_r. (3 x 18), then
    // the block for each l.
    const int* codes = codes_.data() + code_offsets_[e];
    for (int k = 0; k < ns; ++k) {
      t.setZero();
      for (int r = 0; r < 6; ++r) t += b.shape(r, k) * h.block<3, 18>(3 * r, 0);
      for (int l = 0; l < ns; ++l) {
        const int code = codes[k * ns + l];
        if (code < 0) continue;
        Eigen::Matrix3d blk = Eigen::Matrix3d::Zero();
        for (int s = 0; s < 6; ++s) blk += b.shape(s, l) * t.block<3, 3>(0, 3 * s);
        matrix_.add(code, blk);
      }
    }
  }
  return matrix_.matrix();
}

Diameters loop_surface_diameters(const LoopContinuumModel& model, const Positions& x) {
  // Candidates: the limit points at the mesh's vertices, their extremes in x and their octagon
  // of extremes in (y, z) (directions k * 45 degrees from +y, counter-clockwise).
  const Positions at_vertices = (model.vertex_sampling * x.transpose()).transpose();
  const Eigen::Index nv = at_vertices.cols();
  const double x_max = at_vertices.row(0).maxCoeff(), x_min = at_vertices.row(0).minCoeff();
  static constexpr double cy[8] = {1, 1, 0, -1, -1, -1, 0, 1}, cz[8] = {0, 1, 1, 1, 0, -1, -1, -1};
  Eigen::Vector2d octagon[8];
  for (int k = 0; k < 8; ++k) {
    Eigen::Index best = 0;
    for (Eigen::Index i = 1; i < nv; ++i)
      if (cy[k] * at_vertices(1, i) + cz[k] * at_vertices(2, i) >
          cy[k] * at_vertices(1, best) + cz[k] * at_vertices(2, best))
        best = i;
    octagon[k] = at_vertices.block<2, 1>(1, best);
  }
  auto strictly_inside = [&](const Vec3& p) {
    int edges = 0;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector2d a = octagon[k], b = octagon[(k + 1) % 8];
      if (a == b) continue;
      ++edges;
      if ((b(0) - a(0)) * (p(2) - a(1)) - (b(1) - a(1)) * (p(1) - a(0)) <= 0.0) return false;
    }
    return edges >= 3;
  };
  // A control point that could carry a sample point to an extreme.
  std::vector<char> reaches(static_cast<std::size_t>(x.cols()));
  for (Eigen::Index j = 0; j < x.cols(); ++j) {
    const Vec3 p = x.col(j);
    reaches[static_cast<std::size_t>(j)] = p.x() >= x_max || p.x() <= x_min || !strictly_inside(p);
  }
  const auto& m = model.measure_sampling;
  std::vector<Vec3> kept;
  for (Eigen::Index r = 0; r < m.outerSize(); ++r) {
    bool needed = false;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(m, r); it && !needed; ++it)
      needed = reaches[static_cast<std::size_t>(it.col())] != 0;
    if (!needed) continue;
    Vec3 p = Vec3::Zero();
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(m, r); it; ++it)
      p += it.value() * x.col(it.col());
    kept.push_back(p);
  }
  Positions points(3, nv + static_cast<Eigen::Index>(kept.size()));
  points.leftCols(nv) = at_vertices;
  for (std::size_t i = 0; i < kept.size(); ++i)
    points.col(nv + static_cast<Eigen::Index>(i)) = kept[i];
  return measure_diameters(points);
}

namespace loop_stretch_internal {

// Largest coordinate distance (um) of x from its symmetric part under a reduction.
double asymmetry_um(const SymmetryReduction& r, const Eigen::VectorXd& x) {
  return (expand(r, symmetric_part(r, x)) - x).cwiseAbs().maxCoeff();
}

// The mirrors of the rest control mesh that the bead load keeps: its x entries change sign with
// x (the x -> -x mirror swaps the beads), as the tweezers' shares do.
MeshSymmetry loop_scene_symmetry(const LoopContinuumModel& m) {
  std::vector<int> vertices;
  std::vector<double> share;
  const double largest = m.load.cwiseAbs().maxCoeff();
  for (int i = 0; i < m.topo.num_vertices; ++i)
    if (m.load(3 * i) != 0.0) {
      vertices.push_back(i);
      share.push_back(m.load(3 * i) / largest);
    }
  return keep_invariant(find_mirror_symmetry(m.rest, m.topo), vertices, share, 0,
                        kLoadShareTolerance);
}

}  // namespace loop_stretch_internal

std::vector<LoopStretchPoint> run_loop_stretch(const LoopContinuumModel& model,
                                               const std::vector<double>& forces_pN,
                                               const LoopStretchOptions& options,
                                               const ProgressSink& progress) {
  namespace lsi = loop_stretch_internal;
  options.newton.validate();
  require_integer_in_range("force bisections", options.max_bisections, 0, 30);
  for (double f : forces_pN)
    require_finite_in_range("force", "pN", f, 0.0, kUnbounded, Ends::closed_open);
  const Eigen::Index n = model.rest.cols();
  double force = 0;

  // The full problem: every point, one pass for the energy and the constraints. Its Hessian
  // pattern is built at its first assembly (the mirror path may never need it).
  const LoopPointSet all = loop_all_points(model);
  std::unique_ptr<LoopHessianAssembler> assembler;
  auto evaluate_with = [&model, n, &force](const LoopPointSet& set) {
    return [&model, &set, n, &force](const Eigen::VectorXd& xf, NewtonPoint& p) {
      const Eigen::Map<const Positions> x(xf.data(), 3, n);
      Positions g;
      ConstraintValues c;
      p.value = loop_evaluate(model, set, x, force, &g, &c);
      if (!std::isfinite(p.value)) return false;
      p.grad = flat(g);
      p.c.resize(2);
      p.c << c.area_um2 - model.area0_um2, c.volume_um3 - model.volume0_um3;
      p.c_grad.resize(3 * n, 2);
      p.c_grad.col(0) = flat(c.grad_area);
      p.c_grad.col(1) = flat(c.grad_volume);
      return true;
    };
  };
  NewtonProblem full;
  full.evaluate = evaluate_with(all);
  full.hessian = [&](const Eigen::VectorXd& xf,
                     const Eigen::VectorXd& lambda) -> const Eigen::SparseMatrix<double>& {
    if (!assembler) assembler = std::make_unique<LoopHessianAssembler>(model, all);
    return assembler->assemble(model, Eigen::Map<const Positions>(xf.data(), 3, n), lambda(0),
                               lambda(1));
  };
  full.constraint_scale = Eigen::Vector2d(model.area0_um2, model.volume0_um3);
  ShiftedNewton full_newton(options.newton);

  // The symmetric problem (Symmetry::mirror and a group larger than the identity): one point
  // per orbit; its Hessian over those points reduces to P' H P and to every sector's matrix.
  MeshSymmetry group;
  std::shared_ptr<const SymmetryReduction> reduction;
  LoopPointSet orbits;
  std::unique_ptr<LoopHessianAssembler> orbit_assembler;
  std::unique_ptr<ReducedMatrix> reduce_map;
  std::unique_ptr<SymmetryStabilityCheck> stability;
  NewtonProblem reduced;
  ShiftedNewton reduced_newton(options.newton);
  if (options.symmetry == Symmetry::mirror) group = lsi::loop_scene_symmetry(model);
  if (group.order() > 1) {
    reduction = std::make_shared<const SymmetryReduction>(make_symmetry_reduction(group));
    orbits = loop_orbit_points(model, group);
    orbit_assembler = std::make_unique<LoopHessianAssembler>(model, orbits);
    ReducedHessian h = [&](const Eigen::VectorXd& xf,
                           const Eigen::VectorXd& lambda) -> const Eigen::SparseMatrix<double>& {
      const Eigen::SparseMatrix<double>& hf = orbit_assembler->assemble(
          model, Eigen::Map<const Positions>(xf.data(), 3, n), lambda(0), lambda(1));
      if (!reduce_map) reduce_map = std::make_unique<ReducedMatrix>(*reduction, hf);
      return reduce_map->reduce(hf);
    };
    reduced = reduce_newton_problem(full, reduction, nullptr, h, evaluate_with(orbits));
    // The verdict is taken in double, whatever the steps' precision (as the linear element's).
    SparseCholeskyOptions check = options.newton.cholesky;
    check.solve_precision = SolvePrecision::double_precision;
    stability = std::make_unique<SymmetryStabilityCheck>(group, check);
  }

  std::vector<LoopStretchPoint> out;
  Eigen::VectorXd x = flat(model.rest), lambda = Eigen::VectorXd::Zero(2);
  double done = 0;
  bool symmetric = static_cast<bool>(reduction);
  for (double target : forces_pN) {
    const auto t0 = std::chrono::steady_clock::now();
    LoopStretchPoint pt;
    pt.force_pN = target;
    pt.symmetry_order = symmetric ? group.order() : 1;
    Eigen::VectorXd xs = x, ls = lambda;
    double from = done;
    double step = target - from;
    int halvings = 0;
    ShiftedNewtonResult r;
    auto solve = [&](Eigen::VectorXd& xt, Eigen::VectorXd& lt) {
      if (!symmetric) return full_newton.solve(full, xt, lt);
      Eigen::VectorXd q = symmetric_part(*reduction, xt);
      ShiftedNewtonResult rr = reduced_newton.solve(reduced, q, lt);
      xt = expand(*reduction, q);
      return rr;
    };
    while (true) {
      force = from + step;
      Eigen::VectorXd xt = xs, lt = ls;
      r = solve(xt, lt);
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
    if (symmetric && r.status == NewtonStatus::converged) {
      // Is the symmetric equilibrium a minimum in every other sector? The force tolerance's
      // residual fakes a negative curvature along the free rigid turns: allowed for twice over.
      // At a symmetric state the full residual is symmetric, so it is P (P'P)^-1 of the reduced
      // one (P'P: each entry's orbit size), with no full evaluation.
      Eigen::VectorXd rq = r.point.grad + r.point.c_grad * ls;
      for (Eigen::Index i = 0; i < rq.size(); ++i)
        rq(i) /= reduction->orbit_size[static_cast<std::size_t>(
            reduction->orbit_of_entry[static_cast<std::size_t>(i)])];
      const Eigen::VectorXd res = expand(*reduction, rq);
      const double allowance =
          2.0 * rigid_turn_residual_curvature(Eigen::Map<const Positions>(xs.data(), 3, n),
                                              Eigen::Map<const Positions>(res.data(), 3, n));
      const SectorStability st =
          stability->check(orbit_assembler->assemble(
                               model, Eigen::Map<const Positions>(xs.data(), 3, n), ls(0), ls(1)),
                           kSectorShift, allowance);
      pt.stability_factorisations = st.factorisations;
      if (!st.stable) {
        // A saddle: pushed off along its unstable sector and solved in full, from here on.
        symmetric = false;
        pt.symmetry_broken = true;
        pt.symmetry_order = 1;
        Eigen::VectorXd push = stability->sector_direction(st.unstable_character, 1);
        push /= push.cwiseAbs().maxCoeff();
        const Eigen::VectorXd saddle = xs, saddle_lambda = ls;
        double push_um = kSymmetryPushUm;
        for (int attempt = 1; attempt <= kSymmetryPushAttempts;
             ++attempt, push_um *= kSymmetryPushGrowth) {
          Eigen::VectorXd xa = saddle + push_um * push, la = saddle_lambda;
          ShiftedNewtonResult ra = full_newton.solve(full, xa, la);
          pt.iterations += ra.iterations;
          pt.factorisations += ra.factorisations;
          const bool left = ra.status == NewtonStatus::converged &&
                            lsi::asymmetry_um(*reduction, xa) > kSymmetricStartUm;
          if (attempt == 1 || left) {
            r = std::move(ra);
            xs = std::move(xa);
            ls = std::move(la);
          }
          if (left || r.status == NewtonStatus::infeasible_start) break;
        }
      }
    }
    pt.status = r.status;
    pt.residual_pN = r.residual;
    if (r.point.c.size() == 2) {
      pt.energy_pNum = r.point.value;
      pt.area_drift = r.point.c(0) / model.area0_um2;
      pt.volume_drift = r.point.c(1) / model.volume0_um3;
    }
    pt.multipliers = {ls(0), ls(1)};
    if (r.status == NewtonStatus::converged) {
      x = xs;
      lambda = ls;
      done = target;
    }
    pt.x = Eigen::Map<const Positions>(xs.data(), 3, n);
    pt.diameters = loop_surface_diameters(model, pt.x);
    pt.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (progress) {
      std::ostringstream msg;
      msg << "F = " << target << " pN: D_A = " << pt.diameters.axial_um
          << " um, D_T = " << pt.diameters.transverse_um << " um, " << pt.iterations
          << " iterations, " << to_string(pt.status) << ", residual " << pt.residual_pN << " pN, "
          << pt.wall_s << " s"
          << (pt.symmetry_broken ? " (symmetric state a saddle: solved in full)" : "");
      report(progress, msg.str());
    }
    out.push_back(std::move(pt));
  }
  return out;
}

}  // namespace rbc
