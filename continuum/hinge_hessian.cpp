#include "continuum/hinge_hessian.hpp"

#include <unsupported/Eigen/AutoDiff>

namespace rbc {

namespace {

using Jet = Eigen::AutoDiffScalar<Eigen::Matrix<double, 12, 1>>;

/// The analytic gradient of q = L theta (core/geometry.hpp dihedral_angle and discrete/
/// hinge_length_angle), written for any scalar type so that jets differentiate it.
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
  if (!hess) {
    Eigen::Matrix<double, 3, 4> g;
    const double q = hinge_value_gradient<double>(a, b, c, d, g);
    if (grad) *grad = g;
    return q;
  }
  using JV = Eigen::Matrix<Jet, 3, 1>;
  const Vec3* p[4] = {&a, &b, &c, &d};
  JV v[4];
  for (int k = 0; k < 4; ++k)
    for (int i = 0; i < 3; ++i) v[k](i) = Jet((*p[k])(i), 12, 3 * k + i);
  Eigen::Matrix<Jet, 3, 4> g;
  const Jet q = hinge_value_gradient<Jet>(v[0], v[1], v[2], v[3], g);
  for (int k = 0; k < 4; ++k)
    for (int i = 0; i < 3; ++i) {
      hess->row(3 * k + i) = g(i, k).derivatives().transpose();
      if (grad) (*grad)(i, k) = g(i, k).value();
    }
  *hess = 0.5 * (*hess + hess->transpose()).eval();
  return q.value();
}

}  // namespace rbc
