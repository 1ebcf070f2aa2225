// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/periodic_network.hpp"

#include <Eigen/SparseCholesky>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/shifted_newton.hpp"
#include "core/units.hpp"
#include "discrete/link_energy.hpp"

namespace rbc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// One element as seen by the assembly: k = 1 (link) or 2 (face) vectors
/// d_m = F ref_m + u[head_m] - u[tail_m].
struct LocalElement {
  int k = 1;
  std::array<int, 2> head{}, tail{};
  std::array<Eigen::Vector2d, 2> ref;
};

/// Local energy of a link in its vector d (pN um), gradient (pN) and Hessian (pN/um), from
/// the discrete/ kernel with the network embedded at z = 0.
double local_link(const NetworkMaterial& m, const PeriodicEdge& e, const Eigen::Vector2d& d,
                  Eigen::Matrix<double, 4, 1>& g, Eigen::Matrix4d& h, bool want_hessian) {
  Eigen::Vector3d g3 = Eigen::Vector3d::Zero();
  Eigen::Matrix3d h3 = Eigen::Matrix3d::Zero();
  const double E =
      link_energy(m.w, e.lbar_um, Eigen::Vector3d::Zero(), Eigen::Vector3d(d.x(), d.y(), 0.0), &g3,
                  want_hessian ? &h3 : nullptr);
  if (!(E < kInf)) return kInf;
  g.head<2>() = g3.head<2>();
  if (want_hessian) h.topLeftCorner<2, 2>() = h3.topLeftCorner<2, 2>();
  return E;
}

/// Local energy of a face in (e1, e2): the discrete/ steric kernel for value and gradient;
/// Hessian from the steric term's chain rule (steric_face_terms) with the planar area
/// A = (e1 x e2)/2, grad A = (e2y, -e2x, -e1y, e1x)/2 and its constant Hessian.
double local_face(const NetworkMaterial& m, const PeriodicFace& f, const Eigen::Vector2d& e1,
                  const Eigen::Vector2d& e2, Eigen::Matrix<double, 4, 1>& g, Eigen::Matrix4d& h,
                  bool want_hessian) {
  const double area = 0.5 * (e1.x() * e2.y() - e1.y() * e2.x());
  if (!(area > 0.0)) return kInf;  // inverted or collapsed: outside the domain
  Eigen::Matrix3d G;
  const double E = steric_face_energy(m.C_pN_per_um, m.steric, f.abar_um2, Eigen::Vector3d::Zero(),
                                      Eigen::Vector3d(e1.x(), e1.y(), 0.0),
                                      Eigen::Vector3d(e2.x(), e2.y(), 0.0), &G);
  g << G(0, 1), G(1, 1), G(0, 2), G(1, 2);
  if (want_hessian) {
    const Eigen::Vector4d ga(0.5 * e2.y(), -0.5 * e2.x(), -0.5 * e1.y(), 0.5 * e1.x());
    Eigen::Matrix4d ha = Eigen::Matrix4d::Zero();
    ha(0, 3) = ha(3, 0) = 0.5;
    ha(1, 2) = ha(2, 1) = -0.5;
    steric_face_terms<4>(m.C_pN_per_um, m.steric, f.abar_um2, area, ga, &ha, nullptr, &h);
  }
  return E;
}

/// Visits every element with its local energy, gradient in the local vectors and (if
/// requested) Hessian. Stops and returns +infinity at the first infeasible element.
template <class Visit>
double for_each_element(const PeriodicNetwork& net, const NetworkMaterial& m,
                        const Eigen::Matrix2d& F, const Eigen::Matrix2Xd& U, bool want_hessian,
                        Visit&& visit) {
  double total = 0.0;
  Eigen::Matrix<double, 4, 1> g = Eigen::Matrix<double, 4, 1>::Zero();
  Eigen::Matrix4d h = Eigen::Matrix4d::Zero();
  for (const PeriodicEdge& e : net.edges) {
    LocalElement le;
    le.k = 1;
    le.head = {e.j, 0};
    le.tail = {e.i, 0};
    le.ref[0] = e.ref;
    const Eigen::Vector2d d = F * e.ref + U.col(e.j) - U.col(e.i);
    const double E = local_link(m, e, d, g, h, want_hessian);
    if (!(E < kInf)) return kInf;
    total += E;
    visit(le, g, h);
  }
  for (const PeriodicFace& f : net.faces) {
    LocalElement le;
    le.k = 2;
    le.head = {f.v[1], f.v[2]};
    le.tail = {f.v[0], f.v[0]};
    le.ref = {f.e1, f.e2};
    const Eigen::Vector2d e1 = F * f.e1 + U.col(f.v[1]) - U.col(f.v[0]);
    const Eigen::Vector2d e2 = F * f.e2 + U.col(f.v[2]) - U.col(f.v[0]);
    const double E = local_face(m, f, e1, e2, g, h, want_hessian);
    if (!(E < kInf)) return kInf;
    total += E;
    visit(le, g, h);
  }
  return total;
}

Eigen::Matrix2Xd zero_if_empty(const PeriodicNetwork& net, Eigen::Matrix2Xd U) {
  if (U.cols() == 0) return Eigen::Matrix2Xd::Zero(2, net.vertex_count());
  if (U.cols() != net.vertex_count())
    throw std::invalid_argument("cell problem: displacement field has " + std::to_string(U.cols()) +
                                " columns, expected " + std::to_string(net.vertex_count()));
  return U;
}

void check_deformation(const Eigen::Matrix2d& F) {
  if (!(F.determinant() > 0.0) || !F.allFinite())
    throw std::invalid_argument("deformation gradient must have det F > 0, got det F = " +
                                std::to_string(F.determinant()));
}

}  // namespace

PeriodicNetwork make_hexagonal_patch(int n, double a) {
  if (n < 1)
    throw std::invalid_argument("hexagonal patch: n must be >= 1, got " + std::to_string(n));
  if (!(a > 0)) throw std::invalid_argument("hexagonal patch: spacing must be positive");
  const Eigen::Vector2d g1(a, 0.0), g2(0.5 * a, 0.5 * units::sqrt3 * a);
  PeriodicNetwork net;
  net.box.col(0) = n * g1;
  net.box.col(1) = n * g2;
  net.points.resize(2, n * n);
  auto id = [n](int i, int j) { return ((i % n + n) % n) + n * ((j % n + n) % n); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) net.points.col(id(i, j)) = i * g1 + j * g2;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int v = id(i, j);
      for (const auto& [di, dj, ref] : {std::tuple{1, 0, g1}, std::tuple{0, 1, g2},
                                        std::tuple{-1, 1, Eigen::Vector2d(g2 - g1)}})
        net.edges.push_back({v, id(i + di, j + dj), ref, ref.norm()});
      const double abar = 0.25 * units::sqrt3 * a * a;
      net.faces.push_back({{v, id(i + 1, j), id(i, j + 1)}, g1, g2, abar});
      net.faces.push_back({{id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)}, g2, g2 - g1, abar});
    }
  return net;
}

std::vector<int> vertex_degrees(const PeriodicNetwork& net) {
  std::vector<int> deg(net.vertex_count(), 0);
  for (const PeriodicEdge& e : net.edges) {
    ++deg[e.i];
    ++deg[e.j];
  }
  return deg;
}

NetworkMaterial make_network_material(const WlcParameters& p, const StericParameters& s,
                                      WlcExpansion expansion) {
  NetworkMaterial m;
  m.w = make_wlc_density(p, expansion);
  m.steric = s;
  m.C_pN_per_um = steric_constant(m.w, s);
  return m;
}

double patch_energy(const PeriodicNetwork& net, const NetworkMaterial& m, const Eigen::Matrix2d& F,
                    const Eigen::Matrix2Xd& U, Eigen::Matrix2Xd* grad_u, Eigen::Matrix2d* grad_F) {
  Eigen::Matrix2Xd gu = Eigen::Matrix2Xd::Zero(2, net.vertex_count());
  Eigen::Matrix2d gF = Eigen::Matrix2d::Zero();
  const bool want = grad_u || grad_F;
  const double E = for_each_element(
      net, m, F, U, false,
      [&](const LocalElement& le, const Eigen::Matrix<double, 4, 1>& g, const Eigen::Matrix4d&) {
        if (!want) return;
        for (int k = 0; k < le.k; ++k) {
          const Eigen::Vector2d gk = g.segment<2>(2 * k);
          gu.col(le.head[k]) += gk;
          gu.col(le.tail[k]) -= gk;
          gF += gk * le.ref[k].transpose();
        }
      });
  if (E < kInf) {
    if (grad_u) *grad_u = gu;
    if (grad_F) *grad_F = gF;
  }
  return E;
}

PatchHessian patch_hessian(const PeriodicNetwork& net, const NetworkMaterial& m,
                           const Eigen::Matrix2d& F, const Eigen::Matrix2Xd& U) {
  const int nu = 2 * (net.vertex_count() - 1);
  PatchHessian H;
  H.uf = Eigen::MatrixXd::Zero(nu, 4);
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(net.edges.size() * 16 + net.faces.size() * 36);
  const double E = for_each_element(
      net, m, F, U, true,
      [&](const LocalElement& le, const Eigen::Matrix<double, 4, 1>&, const Eigen::Matrix4d& h) {
        // Local unknowns: up to 3 vertices (2 each) then the 4 entries of F.
        std::array<int, 3> verts{};
        int nv = 0;
        auto slot = [&](int v) {
          for (int s = 0; s < nv; ++s)
            if (verts[s] == v) return s;
          verts[nv] = v;
          return nv++;
        };
        Eigen::Matrix<double, 4, 10> Jl = Eigen::Matrix<double, 4, 10>::Zero();
        std::array<int, 2> sh{}, stl{};
        for (int k = 0; k < le.k; ++k) {
          sh[k] = slot(le.head[k]);
          stl[k] = slot(le.tail[k]);
        }
        for (int k = 0; k < le.k; ++k)
          for (int r = 0; r < 2; ++r) {
            Jl(2 * k + r, 2 * sh[k] + r) += 1.0;
            Jl(2 * k + r, 2 * stl[k] + r) -= 1.0;
            Jl(2 * k + r, 2 * nv + 2 * r + 0) = le.ref[k].x();
            Jl(2 * k + r, 2 * nv + 2 * r + 1) = le.ref[k].y();
          }
        // Rows beyond 2k and columns beyond 2 nv + 4 of Jl are zero: fixed-size products.
        const int cols = 2 * nv + 4;
        Eigen::Matrix4d hk = Eigen::Matrix4d::Zero();
        hk.topLeftCorner(2 * le.k, 2 * le.k) = h.topLeftCorner(2 * le.k, 2 * le.k);
        const Eigen::Matrix<double, 10, 10> Hl = Jl.transpose() * hk * Jl;
        auto global = [&](int c) {  // reduced index of a vertex column, -1 if pinned; F: -2 - k
          if (c >= 2 * nv) return -2 - (c - 2 * nv);
          const int v = verts[c / 2];
          return v == 0 ? -1 : 2 * (v - 1) + c % 2;
        };
        for (int a = 0; a < cols; ++a) {
          const int ga = global(a);
          if (ga == -1) continue;
          for (int b = 0; b < cols; ++b) {
            const int gb = global(b);
            if (gb == -1) continue;
            if (ga >= 0 && gb >= 0)
              trip.emplace_back(ga, gb, Hl(a, b));
            else if (ga >= 0 && gb <= -2)
              H.uf(ga, -2 - gb) += Hl(a, b);
            else if (ga <= -2 && gb <= -2)
              H.ff(-2 - ga, -2 - gb) += Hl(a, b);
          }
        }
      });
  if (!(E < kInf))
    throw std::invalid_argument("cell problem: Hessian requested outside the energy's domain");
  H.uu.resize(nu, nu);
  H.uu.setFromTriplets(trip.begin(), trip.end());
  return H;
}

CellRelaxResult relax_patch(const PeriodicNetwork& net, const NetworkMaterial& m,
                            const Eigen::Matrix2d& F, Eigen::Matrix2Xd U0,
                            const RelaxOptions& options) {
  check_deformation(F);
  CellRelaxResult r;
  r.U = zero_if_empty(net, std::move(U0));
  for (int v = net.vertex_count() - 1; v >= 0; --v) r.U.col(v) -= r.U.col(0);  // pin vertex 0
  const int N = net.vertex_count();
  const int nu = 2 * (N - 1);
  Eigen::Matrix2Xd g;
  double E = patch_energy(net, m, F, r.U, &g);
  if (!(E < kInf)) {
    r.status = MinimiserStatus::infeasible_start;
    r.energy_pNum = E;
    return r;
  }
  // The project's shifted Newton (core/shifted_newton.hpp) on the reduced unknowns (vertex
  // 0 pinned), unconstrained: no shift while the Hessian is positive definite, else 1e-8 x
  // its largest diagonal entry growing tenfold (Levenberg); Armijo backtracking whose slack
  // 16 eps |E| accepts steps whose decrease is below round-off (the last Newton steps, where
  // the gradient norm is what still improves). The Hessian's sparsity pattern (links and
  // faces) is the same at every iterate and shift: its ordering and symbolic factorisation
  // are computed once, only the numbers per attempt.
  ShiftedNewtonOptions no;
  no.force_tolerance = options.force_tolerance_pN;
  no.max_iterations = options.max_iterations;
  no.block_size = 2;
  no.max_line_search = 60;
  no.armijo_slack_rel = 16 * std::numeric_limits<double>::epsilon();
  no.roundoff_merit_rel = 0.0;
  no.initial_shift = 0.0;
  no.retry_shift = 1e-8;
  no.shift_memory = 0.0;
  no.shift_scale = ShiftScale::max_abs_diagonal;
  no.max_factor_reuse = 0;
  no.stall_iterations = options.stall_iterations;
  no.max_shift_attempts = options.max_shift_attempts;
  no.floor_factor = options.floor_factor;
  no.cholesky.ordering = FillOrdering::amd;
  no.cholesky.supernodal_min_unknowns = std::numeric_limits<int>::max();  // simplicial
  no.cholesky.blas_threads = 0;  // simplicial LL' calls no BLAS: leave the thread counts alone
  no.cancel = options.cancel;
  Eigen::Matrix2Xd trial = r.U;  // vertex 0 stays at zero
  auto full = [&](const Eigen::VectorXd& xr) -> const Eigen::Matrix2Xd& {
    trial.rightCols(N - 1) = Eigen::Map<const Eigen::Matrix2Xd>(xr.data(), 2, N - 1);
    return trial;
  };
  NewtonProblem pb;
  pb.evaluate = [&](const Eigen::VectorXd& xr, NewtonPoint& p) {
    Eigen::Matrix2Xd gt;
    p.value = patch_energy(net, m, F, full(xr), &gt);
    if (!(p.value < kInf)) return false;
    p.grad = Eigen::Map<const Eigen::VectorXd>(gt.data() + 2, nu);
    return true;
  };
  Eigen::SparseMatrix<double> H;
  pb.hessian = [&](const Eigen::VectorXd& xr,
                   const Eigen::VectorXd&) -> const Eigen::SparseMatrix<double>& {
    H = patch_hessian(net, m, F, full(xr)).uu;
    H.makeCompressed();
    return H;
  };
  Eigen::VectorXd xr = Eigen::Map<const Eigen::VectorXd>(r.U.data() + 2, nu);
  Eigen::VectorXd no_lambda;
  ShiftedNewton newton(no);
  const ShiftedNewtonResult nr = newton.solve(pb, xr, no_lambda);
  r.iterations = nr.iterations;
  r.residual_pN = nr.residual;
  r.at_roundoff_floor = nr.at_roundoff_floor;
  r.status = minimiser_status(nr.status);
  r.U = full(xr);
  E = nr.point.value;
  r.energy_pNum = E;
  r.max_displacement_um = N > 0 ? r.U.colwise().norm().maxCoeff() : 0.0;
  return r;
}

HomogenisedState homogenise_patch(const PeriodicNetwork& net, const NetworkMaterial& m,
                                  const Eigen::Matrix2d& F, Eigen::Matrix2Xd U0,
                                  const RelaxOptions& options) {
  HomogenisedState s;
  s.relax = relax_patch(net, m, F, std::move(U0), options);
  const double area = net.reference_area_um2();
  if (!(s.relax.energy_pNum < kInf)) {
    s.psi_pN_per_um = kInf;
    return s;
  }
  Eigen::Matrix2d gF;
  Eigen::Matrix2Xd gu;
  s.psi_pN_per_um = patch_energy(net, m, F, s.relax.U, &gu, &gF) / area;
  s.stress = gF / area;
  const PatchHessian H = patch_hessian(net, m, F, s.relax.U);
  s.affine_tangent = H.ff / area;
  if (H.uu.rows() > 0) {
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(H.uu);
    if (ldlt.info() != Eigen::Success)
      throw std::runtime_error("cell problem: internal Hessian could not be factorised");
    const Eigen::MatrixXd X = ldlt.solve(H.uf);
    s.relaxed_tangent = (H.ff - H.uf.transpose() * X) / area;
  } else {
    s.relaxed_tangent = s.affine_tangent;
  }
  return s;
}

LinearModuli moduli_from_tangent(const Eigen::Matrix4d& T) {
  const FlatF d1(1, 0, 0, -1), d2(0, 1, 1, 0), id(1, 0, 0, 1);
  LinearModuli m;
  m.mu_pN_per_um = (d1.dot(T * d1) + d2.dot(T * d2)) / 8.0;
  m.K_pN_per_um = id.dot(T * id) / 4.0;
  return m;
}

}  // namespace rbc
