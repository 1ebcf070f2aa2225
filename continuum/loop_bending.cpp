// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/loop_bending.hpp"

#include <cmath>
#include <limits>

#include "continuum/loop_terms.hpp"

namespace rbc {

namespace loop_bending_internal {

using Vector15d = Eigen::Matrix<double, 15, 1>;
using Matrix15d = Eigen::Matrix<double, 15, 15>;

// Adds c (u v' + v u') to h.
void add_sym_outer(Matrix15d& h, double c, const Vector15d& u, const Vector15d& v) {
  h.noalias() += c * (u * v.transpose() + v * u.transpose());
}

}  // namespace loop_bending_internal

LoopJet loop_jet(const LoopBasis& basis, const Positions& x) {
  LoopJet jet;
  for (Vec3& d : jet) d.setZero();
  for (std::size_t k = 0; k < basis.vertices.size(); ++k) {
    const Vec3 xk = x.col(basis.vertices[k]);
    for (int r = 0; r < 5; ++r) jet[r] += basis.shape(1 + r, static_cast<Eigen::Index>(k)) * xk;
  }
  return jet;
}

double loop_mean_curvature(const LoopJet& jet) {
  const Vec3 m = jet[0].cross(jet[1]);
  const double j2 = m.squaredNorm(), j = std::sqrt(j2);
  const double num = jet[1].squaredNorm() * jet[2].dot(m) - 2 * jet[0].dot(jet[1]) * jet[3].dot(m) +
                     jet[0].squaredNorm() * jet[4].dot(m);
  return -num / (j2 * j);
}

double loop_helfrich_density(const BendingParameters& params, const LoopJet& jet,
                             LoopJetGradient* grad, LoopJetHessian* hess) {
  namespace lbi = loop_bending_internal;
  const Vec3 &a = jet[0], &b = jet[1];
  const Vec3 m = a.cross(b);
  const double j2 = m.squaredNorm();
  if (j2 == 0.0) return std::numeric_limits<double>::infinity();
  const double kappa = params.kappa_pNum, h0 = params.h0_per_um;
  // Primitives: metric g11 = a.a, g12 = a.b, g22 = b.b; q_k = s_k . m for s = (x_vv, x_vw,
  // x_ww); J2 = m.m. Then N = g22 q1 - 2 g12 q2 + g11 q3, H = -N J2^(-3/2),
  // e = (kappa/2) (H - H0)^2 J2^(1/2).
  const double g11 = a.dot(a), g12 = a.dot(b), g22 = b.dot(b);
  const double q[3] = {jet[2].dot(m), jet[3].dot(m), jet[4].dot(m)};
  const double n = g22 * q[0] - 2 * g12 * q[1] + g11 * q[2];
  const double w = std::sqrt(j2), u = 1.0 / (j2 * w);
  const double h = -n * u, d = h - h0;
  const double e = 0.5 * kappa * d * d * w;
  if (grad == nullptr && hess == nullptr) return e;
  // Derivatives of e in (N, J2).
  const double du = -1.5 * u / j2, d2u = 3.75 * u / (j2 * j2);
  const double dw = 0.5 / w, d2w = -0.25 / (w * j2);
  const double hn = -u, hj = -n * du, hnj = -du, hjj = -n * d2u;
  const double en = kappa * d * hn * w;
  const double ej = kappa * d * hj * w + 0.5 * kappa * d * d * dw;
  // Gradients (15: a, b, s1, s2, s3) of the primitives.
  using V = lbi::Vector15d;
  V dg11 = V::Zero(), dg12 = V::Zero(), dg22 = V::Zero(), dj2 = V::Zero(), dq[3];
  dg11.segment<3>(0) = 2 * a;
  dg12.segment<3>(0) = b;
  dg12.segment<3>(3) = a;
  dg22.segment<3>(3) = 2 * b;
  Vector6d dj2_ab;
  Matrix6d d2j2_ab;
  loop_cross_norm2(a, b, &dj2_ab, hess != nullptr ? &d2j2_ab : nullptr);
  dj2.head<6>() = dj2_ab;
  for (int k = 0; k < 3; ++k) {
    const Vec3& sk = jet[2 + k];
    dq[k].setZero();
    dq[k].segment<3>(0) = b.cross(sk);
    dq[k].segment<3>(3) = sk.cross(a);
    dq[k].segment<3>(6 + 3 * k) = m;
  }
  const V dn =
      q[0] * dg22 + g22 * dq[0] - 2 * (q[1] * dg12 + g12 * dq[1]) + q[2] * dg11 + g11 * dq[2];
  if (grad != nullptr) *grad = en * dn + ej * dj2;
  if (hess == nullptr) return e;
  const double enn = kappa * hn * hn * w;
  const double enj = kappa * (hj * hn * w + d * hnj * w + d * hn * dw);
  const double ejj =
      kappa * (hj * hj * w + d * hjj * w + 2 * d * hj * dw) + 0.5 * kappa * d * d * d2w;
  const Eigen::Matrix3d id = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d ma = -cross_matrix(b), mb = cross_matrix(a);  // dm = ma da + mb db
  // Hessian of J2 (only the (a, b) 6 x 6 part is nonzero).
  lbi::Matrix15d d2j2 = lbi::Matrix15d::Zero();
  d2j2.block<6, 6>(0, 0) = d2j2_ab;
  // Hessian of N: the primitives' Hessians times N's first partials, plus its bilinear terms.
  lbi::Matrix15d d2n = lbi::Matrix15d::Zero();
  d2n.block<3, 3>(3, 3) += 2 * q[0] * id;                                            // q1 d2 g22
  d2n.block<3, 3>(0, 3) += -2 * q[1] * id, d2n.block<3, 3>(3, 0) += -2 * q[1] * id;  // -2 q2 d2 g12
  d2n.block<3, 3>(0, 0) += 2 * q[2] * id;                                            // q3 d2 g11
  const double coef[3] = {g22, -2 * g12, g11};
  for (int k = 0; k < 3; ++k) {
    // d2 q_k: (s_k, a) = ma, (s_k, b) = mb, (a, b) = -skew(s_k), and the transposes.
    const int sk = 6 + 3 * k;
    const Eigen::Matrix3d ab = -cross_matrix(jet[2 + k]);
    d2n.block<3, 3>(sk, 0) += coef[k] * ma;
    d2n.block<3, 3>(0, sk) += coef[k] * ma.transpose();
    d2n.block<3, 3>(sk, 3) += coef[k] * mb;
    d2n.block<3, 3>(3, sk) += coef[k] * mb.transpose();
    d2n.block<3, 3>(0, 3) += coef[k] * ab;
    d2n.block<3, 3>(3, 0) += coef[k] * ab.transpose();
  }
  lbi::add_sym_outer(d2n, 1.0, dg22, dq[0]);
  lbi::add_sym_outer(d2n, -2.0, dg12, dq[1]);
  lbi::add_sym_outer(d2n, 1.0, dg11, dq[2]);
  *hess = enn * dn * dn.transpose() + ejj * dj2 * dj2.transpose() + en * d2n + ej * d2j2;
  lbi::add_sym_outer(*hess, enj, dn, dj2);
  return e;
}

double loop_helfrich_energy(const std::vector<LoopQuadraturePoint>& q, const Positions& x,
                            const BendingParameters& params, Positions* grad,
                            Eigen::SparseMatrix<double>* hess) {
  double energy = 0;
  std::vector<Eigen::Triplet<double>> trip;
  LoopJetGradient g;
  LoopJetHessian h;
  for (const LoopQuadraturePoint& p : q) {
    const LoopJet jet = loop_jet(p.basis, x);
    const double e =
        loop_helfrich_density(params, jet, grad != nullptr || hess != nullptr ? &g : nullptr,
                              hess != nullptr ? &h : nullptr);
    energy += p.weight * e;
    if (!std::isfinite(e) || (grad == nullptr && hess == nullptr)) continue;
    const Eigen::VectorXd gl = p.weight * g;
    const Eigen::MatrixXd hl = hess != nullptr ? Eigen::MatrixXd(p.weight * h) : Eigen::MatrixXd();
    add_loop_point_derivatives(p.basis, 1, 5, gl, hess != nullptr ? &hl : nullptr, grad,
                               hess != nullptr ? &trip : nullptr);
  }
  if (hess != nullptr) {
    hess->resize(x.size(), x.size());
    hess->setFromTriplets(trip.begin(), trip.end());
  }
  return energy;
}

double loop_surface_area(const std::vector<LoopQuadraturePoint>& q, const Positions& x) {
  double area = 0;
  for (const LoopQuadraturePoint& p : q) {
    const LoopJet jet = loop_jet(p.basis, x);
    area += p.weight * jet[0].cross(jet[1]).norm();
  }
  return area;
}

}  // namespace rbc
