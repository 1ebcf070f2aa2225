// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/element_hessian.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <unsupported/Eigen/AutoDiff>

namespace rbc {
namespace {

/// The analytic value and gradient of q = L theta (as core/geometry.hpp dihedral_angle and
/// bending_energy.cpp hinge_length_angle), for any scalar type so that jets differentiate it.
template <class T>
T hinge_value_gradient(const Eigen::Matrix<T, 3, 1>& a, const Eigen::Matrix<T, 3, 1>& b,
                       const Eigen::Matrix<T, 3, 1>& c, const Eigen::Matrix<T, 3, 1>& d,
                       Eigen::Matrix<T, 3, 4>& grad) {
  using std::atan2;
  using std::sqrt;
  using V = Eigen::Matrix<T, 3, 1>;
  const V e = b - a;
  const V m0 = e.cross(c - a);
  const V m1 = (a - b).cross(d - b);
  const T e2 = e.squaredNorm();
  const T el = sqrt(e2);
  const T theta = atan2(m0.cross(m1).dot(e) / el, m0.dot(m1));
  const V gc = -(el / m0.squaredNorm()) * m0;
  const V gd = -(el / m1.squaredNorm()) * m1;
  const T tc = (c - a).dot(e) / e2, td = (d - a).dot(e) / e2;
  const T one(1.0);
  grad.col(0) = el * (-(one - tc) * gc - (one - td) * gd) - (theta / el) * e;
  grad.col(1) = el * (-tc * gc - td * gd) + (theta / el) * e;
  grad.col(2) = el * gc;
  grad.col(3) = el * gd;
  return el * theta;
}

}  // namespace

double hinge_length_angle_hessian_autodiff(const Vec3& a, const Vec3& b, const Vec3& c,
                                           const Vec3& d, Eigen::Matrix<double, 3, 4>* grad,
                                           Matrix12d* hess) {
  using Jet = Eigen::AutoDiffScalar<Eigen::Matrix<double, 12, 1>>;
  using JV = Eigen::Matrix<Jet, 3, 1>;
  const Vec3* p[4] = {&a, &b, &c, &d};
  JV v[4];
  for (int k = 0; k < 4; ++k)
    for (int i = 0; i < 3; ++i) v[k](i) = Jet((*p[k])(i), 12, 3 * k + i);
  Eigen::Matrix<Jet, 3, 4> g;
  const Jet q = hinge_value_gradient<Jet>(v[0], v[1], v[2], v[3], g);
  Matrix12d h;
  for (int k = 0; k < 4; ++k)
    for (int i = 0; i < 3; ++i) {
      h.row(3 * k + i) = g(i, k).derivatives().transpose();
      if (grad) (*grad)(i, k) = g(i, k).value();
    }
  if (hess) *hess = 0.5 * (h + h.transpose());
  return q.value();
}

double hinge_length_angle_hessian(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                  Eigen::Matrix<double, 3, 4>* grad, Matrix12d* hess) {
  using M3 = Eigen::Matrix3d;
  const Vec3 e = b - a, w = c - a, w2 = d - a, wb = d - b;
  const Vec3 m0 = e.cross(w);
  const Vec3 m1 = (a - b).cross(wb);
  const double e2 = e.squaredNorm(), el = std::sqrt(e2);
  const double theta = std::atan2(m0.cross(m1).dot(e) / el, m0.dot(m1));
  const double s0 = m0.squaredNorm(), s1 = m1.squaredNorm();
  const Vec3 gc = -(el / s0) * m0, gd = -(el / s1) * m1;  // dtheta/dc, dtheta/dd
  const double tc = w.dot(e) / e2, td = w2.dot(e) / e2;
  const Vec3 ga = -(1.0 - tc) * gc - (1.0 - td) * gd, gb = -tc * gc - td * gd;
  const Vec3 eh = e / el;
  if (grad) {
    grad->col(0) = el * ga - (theta / el) * e;
    grad->col(1) = el * gb + (theta / el) * e;
    grad->col(2) = el * gc;
    grad->col(3) = el * gd;
  }
  if (hess) {
    // Jacobians of gc(a, b, c) and gd(a, b, d): g = -L m/|m|^2 gives
    // dg = -(m/|m|^2) dL - (L/|m|^2)(I - 2 m m^T/|m|^2) dm, with dL = eh.(db - da),
    // dm0 = [c - b]_x da - [c - a]_x db + [e]_x dc, dm1 = -[d - b]_x da + [d - a]_x db - [e]_x dd.
    const Vec3 u0 = m0 / s0, u1 = m1 / s1;
    const M3 p0 = (el / s0) * (M3::Identity() - 2.0 * u0 * m0.transpose());
    const M3 p1 = (el / s1) * (M3::Identity() - 2.0 * u1 * m1.transpose());
    const M3 u0e = u0 * eh.transpose(), u1e = u1 * eh.transpose();
    const M3 ex = cross_matrix(e);
    const M3 jc[3] = {u0e - p0 * cross_matrix(c - b), p0 * cross_matrix(w) - u0e, -p0 * ex};
    const M3 jd[3] = {u1e + p1 * cross_matrix(wb), -u1e - p1 * cross_matrix(w2), p1 * ex};
    // Gradients of tc = (c - a).e/|e|^2 and td = (d - a).e/|e|^2 (columns a, b, c or d).
    const Vec3 rw = e / e2, rc = (w - 2.0 * tc * e) / e2, rd = (w2 - 2.0 * td * e) / e2;
    const Vec3 dtc[3] = {-rc - rw, rc, rw};
    const Vec3 dtd[3] = {-rd - rw, rd, rw};
    // d2theta, block rows a, b, c, d; column k of jc is vertex (a, b, c)[k], of jd (a, b, d)[k].
    M3 ht[4][4];
    const int col_c[3] = {0, 1, 2}, col_d[3] = {0, 1, 3};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) ht[i][j].setZero();
    for (int k = 0; k < 3; ++k) {
      const int kc = col_c[k], kd = col_d[k];
      ht[2][kc] = jc[k];
      ht[3][kd] = jd[k];
      ht[0][kc] += -(1.0 - tc) * jc[k] + gc * dtc[k].transpose();
      ht[0][kd] += -(1.0 - td) * jd[k] + gd * dtd[k].transpose();
      ht[1][kc] += -tc * jc[k] - gc * dtc[k].transpose();
      ht[1][kd] += -td * jd[k] - gd * dtd[k].transpose();
    }
    // d2q = L d2theta + theta d2L + dL dtheta^T + dtheta dL^T, with dL = (-eh, eh, 0, 0) and
    // d2L = (I - eh eh^T)/L on the (a, b) blocks with signs (+ -; - +).
    const M3 d2l = (theta / el) * (M3::Identity() - eh * eh.transpose());
    const Vec3 gt[4] = {ga, gb, gc, gd};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j <= i; ++j) {
        M3 blk = 0.5 * el * (ht[i][j] + ht[j][i].transpose());
        if (i < 2 && j < 2) blk += (i == j ? 1.0 : -1.0) * d2l;
        if (j < 2) blk += (j == 0 ? -1.0 : 1.0) * gt[i] * eh.transpose();
        if (i < 2) blk += (i == 0 ? -1.0 : 1.0) * eh * gt[j].transpose();
        if (i == j) {
          hess->block<3, 3>(3 * i, 3 * i) = 0.5 * (blk + blk.transpose());  // exactly symmetric
        } else {
          hess->block<3, 3>(3 * i, 3 * j) = blk;
          hess->block<3, 3>(3 * j, 3 * i) = blk.transpose();
        }
      }
  }
  return el * theta;
}

double triangle_area_hessian(const Vec3& a, const Vec3& b, const Vec3& c, Vector9d* grad,
                             Matrix9d* hess) {
  const Vec3 e1 = b - a, e2 = c - a;
  const double g11 = e1.squaredNorm(), g12 = e1.dot(e2), g22 = e2.squaredNorm();
  const double det = g11 * g22 - g12 * g12;
  const double sq = std::sqrt(det);
  // Derivatives in edge variables (e1, e2), then mapped by e1 = b - a, e2 = c - a.
  Eigen::Matrix<double, 6, 1> dD;
  dD.segment<3>(0) = 2.0 * g22 * e1 - 2.0 * g12 * e2;
  dD.segment<3>(3) = 2.0 * g11 * e2 - 2.0 * g12 * e1;
  const Eigen::Matrix<double, 6, 1> dA = dD / (4.0 * sq);
  if (grad) {
    grad->segment<3>(0) = -dA.segment<3>(0) - dA.segment<3>(3);
    grad->segment<3>(3) = dA.segment<3>(0);
    grad->segment<3>(6) = dA.segment<3>(3);
  }
  if (hess) {
    // The projector form (no cancellation between the two terms of the D form):
    // d2A/dx_k dx_l = J_k^T P J_l / (2|n|) -+ [nh]_x/2, with J_k = [v_k]_x, v = (c - b, a - c,
    // b - a) and P = I - nh nh^T. Expanded by -[u]_x [v]_x = (u.v) I - v u^T:
    // J_k^T P J_l = (v_k.v_l) I - v_l v_k^T - w_k w_l^T with w_k = J_k^T nh = nh x v_k
    // (a few dozen flops a block instead of two 3 x 3 products and nine divisions).
    const Vec3 n = e1.cross(e2);
    const double len = n.norm();
    const Vec3 nh = n / len;
    const double inv2len = 0.5 / len;
    const Vec3 v[3] = {c - b, a - c, b - a};
    const Vec3 w[3] = {nh.cross(v[0]), nh.cross(v[1]), nh.cross(v[2])};
    const Eigen::Matrix3d nx = 0.5 * cross_matrix(nh);
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l) {
        Eigen::Matrix3d blk = -inv2len * (v[l] * v[k].transpose() + w[k] * w[l].transpose());
        blk.diagonal().array() += inv2len * v[k].dot(v[l]);
        if (l == (k + 1) % 3) blk -= nx;
        if (k == (l + 1) % 3) blk += nx;
        hess->block<3, 3>(3 * k, 3 * l) = blk;
      }
  }
  return 0.5 * sq;
}

Matrix9d tetra_volume_hessian(const Vec3& a, const Vec3& b, const Vec3& c) {
  Matrix9d h = Matrix9d::Zero();
  h.block<3, 3>(0, 3) = -cross_matrix(c) / 6.0;
  h.block<3, 3>(3, 6) = -cross_matrix(a) / 6.0;
  h.block<3, 3>(6, 0) = -cross_matrix(b) / 6.0;
  h.block<3, 3>(3, 0) = h.block<3, 3>(0, 3).transpose();
  h.block<3, 3>(6, 3) = h.block<3, 3>(3, 6).transpose();
  h.block<3, 3>(0, 6) = h.block<3, 3>(6, 0).transpose();
  return h;
}

template <int K>
void project_positive_semidefinite(Eigen::Matrix<double, K, K>& h) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, K, K>> es(h);
  const auto& ev = es.eigenvalues();
  if (ev(0) >= 0.0) return;  // ascending: already semidefinite
  h = es.eigenvectors() * ev.cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
}

template void project_positive_semidefinite<9>(Eigen::Matrix<double, 9, 9>&);
template void project_positive_semidefinite<12>(Eigen::Matrix<double, 12, 12>&);
template void project_positive_semidefinite<3>(Eigen::Matrix<double, 3, 3>&);
template void project_positive_semidefinite<Eigen::Dynamic>(Eigen::MatrixXd&);  // custom pieces

}  // namespace rbc
