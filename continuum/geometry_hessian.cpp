#include "continuum/geometry_hessian.hpp"

#include "discrete/element_hessian.hpp"

#include <cmath>

namespace rbc {

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
    const Eigen::Matrix3d id = Eigen::Matrix3d::Identity();
    Eigen::Matrix<double, 6, 6> d2D;
    d2D.block<3, 3>(0, 0) = 2.0 * g22 * id - 2.0 * e2 * e2.transpose();
    d2D.block<3, 3>(3, 3) = 2.0 * g11 * id - 2.0 * e1 * e1.transpose();
    d2D.block<3, 3>(0, 3) = 4.0 * e1 * e2.transpose() - 2.0 * e2 * e1.transpose() - 2.0 * g12 * id;
    d2D.block<3, 3>(3, 0) = d2D.block<3, 3>(0, 3).transpose();
    const Eigen::Matrix<double, 6, 6> h = d2D / (4.0 * sq) - dD * dD.transpose() / (8.0 * sq * det);
    Eigen::Matrix<double, 6, 9> map = Eigen::Matrix<double, 6, 9>::Zero();
    map.block<3, 3>(0, 0) = -id;
    map.block<3, 3>(0, 3) = id;
    map.block<3, 3>(3, 0) = -id;
    map.block<3, 3>(3, 6) = id;
    *hess = map.transpose() * h * map;
  }
  return 0.5 * sq;
}

Matrix9d tetra_volume_hessian(const Vec3& a, const Vec3& b, const Vec3& c) {
  return face_volume_hessian(a, b, c);  // discrete/element_hessian.hpp
}

}  // namespace rbc
