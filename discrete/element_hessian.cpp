#include "discrete/element_hessian.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <unsupported/Eigen/AutoDiff>

namespace rbc {
namespace {

Eigen::Matrix3d cross_matrix(const Vec3& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

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

double hinge_length_angle_hessian(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                  Eigen::Matrix<double, 3, 4>* grad, Matrix12d* hess) {
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
    // The projector form (no cancellation between the two terms of the D form).
    const Vec3 n = e1.cross(e2);
    const double len = n.norm();
    const Vec3 nh = n / len;
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - nh * nh.transpose();
    const Eigen::Matrix3d j[3] = {cross_matrix(c - b), cross_matrix(a - c), cross_matrix(b - a)};
    const Eigen::Matrix3d nx = 0.5 * cross_matrix(nh);
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l) {
        Eigen::Matrix3d blk = j[k].transpose() * p * j[l] / (2.0 * len);
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
