// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/loop_terms.hpp"

#include <cmath>
#include <limits>
#include <unsupported/Eigen/AutoDiff>

#include "continuum/membrane_element.hpp"
#include "core/validation.hpp"

namespace rbc {

namespace loop_terms_internal {

template <int N>
using Ad1 = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;
template <int N>
using Ad2 = Eigen::AutoDiffScalar<Eigen::Matrix<Ad1<N>, N, 1>>;

// The N variables z as second-order active scalars.
template <int N>
std::array<Ad2<N>, N> active(const std::array<double, N>& z) {
  std::array<Ad2<N>, N> a;
  for (int i = 0; i < N; ++i) {
    a[i].value() = Ad1<N>(z[i], N, i);
    a[i].derivatives().setZero();
    a[i].derivatives()(i) = Ad1<N>(1.0);
  }
  return a;
}

// Value, gradient and Hessian of a second-order active scalar.
template <int N>
double unpack(const Ad2<N>& s, Eigen::Matrix<double, N, 1>& g, Eigen::Matrix<double, N, N>& h) {
  for (int i = 0; i < N; ++i) {
    g(i) = s.derivatives()(i).value();
    for (int k = 0; k < N; ++k) h(i, k) = s.derivatives()(i).derivatives()(k);
  }
  return s.value().value();
}

template <class T>
T cross_norm(const std::array<T, 6>& z) {
  const T m0 = z[1] * z[5] - z[2] * z[4];
  const T m1 = z[2] * z[3] - z[0] * z[5];
  const T m2 = z[0] * z[4] - z[1] * z[3];
  using std::sqrt;
  return sqrt(m0 * m0 + m1 * m1 + m2 * m2);
}

std::array<double, 6> pack(const Vec3& a, const Vec3& b) {
  return {a(0), a(1), a(2), b(0), b(1), b(2)};
}

}  // namespace loop_terms_internal

LoopMembraneReference make_loop_membrane_reference(const Vec3& xv, const Vec3& xw) {
  Eigen::Matrix2d g;
  g << xv.dot(xv), xv.dot(xw), xv.dot(xw), xw.dot(xw);
  const double det = g.determinant();
  if (!(det > 0))
    throw InvalidParameter("rest surface metric determinant", format_number(det),
                           "positive (non-parallel rest tangents)", "um^4");
  return {g.inverse(), std::sqrt(det)};
}

double loop_membrane_density(const IsotropicMembraneLaw& law, const LoopMembraneReference& ref,
                             const Vec3& xv, const Vec3& xw, Vector6d* grad, Matrix6d* hess) {
  namespace lti = loop_terms_internal;
  const Eigen::Matrix2d& gi = ref.metric_inverse;
  const double jbar = ref.jacobian_um2;
  const double i2 = gi(0, 0) * xv.dot(xv) + 2 * gi(0, 1) * xv.dot(xw) + gi(1, 1) * xw.dot(xw) - 2;
  Vector6d dj;
  Matrix6d d2j;
  const double j = grad != nullptr || hess != nullptr
                       ? lti::unpack<6>(lti::cross_norm(lti::active<6>(lti::pack(xv, xw))), dj, d2j)
                       : xv.cross(xw).norm();
  const double ratio = j / jbar;
  if (!(ratio >= kCollapsedElementRatio)) return std::numeric_limits<double>::infinity();
  const InvariantDerivatives d = law.evaluate(ratio - 1, i2);
  if (!std::isfinite(d.psi)) return std::numeric_limits<double>::infinity();
  if (grad != nullptr || hess != nullptr) {
    // dI1 = dJ / Jbar; dI2 = 2 (G^-1 (x) I3) (x_v, x_w); d2I2 = 2 G^-1 (x) I3.
    Vector6d di2;
    di2.head<3>() = 2 * (gi(0, 0) * xv + gi(0, 1) * xw);
    di2.tail<3>() = 2 * (gi(0, 1) * xv + gi(1, 1) * xw);
    if (grad != nullptr) *grad = d.d1 * dj + jbar * d.d2 * di2;
    if (hess != nullptr) {
      Matrix6d d2i2 = Matrix6d::Zero();
      for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
          d2i2.block<3, 3>(3 * a, 3 * b) = 2 * gi(a, b) * Eigen::Matrix3d::Identity();
      *hess = d.d11 / jbar * dj * dj.transpose() +
              d.d12 * (dj * di2.transpose() + di2 * dj.transpose()) +
              jbar * d.d22 * di2 * di2.transpose() + d.d1 * d2j + jbar * d.d2 * d2i2;
    }
  }
  return jbar * d.psi;
}

double loop_area_density(const Vec3& xv, const Vec3& xw, Vector6d* grad, Matrix6d* hess) {
  namespace lti = loop_terms_internal;
  if (grad == nullptr && hess == nullptr) return xv.cross(xw).norm();
  Vector6d g;
  Matrix6d h;
  const double a = lti::unpack<6>(lti::cross_norm(lti::active<6>(lti::pack(xv, xw))), g, h);
  if (grad != nullptr) *grad = g;
  if (hess != nullptr) *hess = h;
  return a;
}

double loop_volume_density(const Vec3& x, const Vec3& xv, const Vec3& xw, Vector9d* grad,
                           Eigen::Matrix<double, 9, 9>* hess) {
  // v = x . (x_v x x_w) / 3 is trilinear: its derivatives are cross products, written out.
  const double v = x.dot(xv.cross(xw)) / 3.0;
  if (grad != nullptr) {
    grad->segment<3>(0) = xv.cross(xw) / 3.0;
    grad->segment<3>(3) = xw.cross(x) / 3.0;
    grad->segment<3>(6) = x.cross(xv) / 3.0;
  }
  if (hess != nullptr) {
    // d2v / dp dq for the pairs (x, x_v), (x, x_w), (x_v, x_w): the skew matrices of the third.
    auto skew = [](const Vec3& a) {
      Eigen::Matrix3d s;
      s << 0, -a(2), a(1), a(2), 0, -a(0), -a(1), a(0), 0;
      return s;
    };
    hess->setZero();
    // d/dx_v (d v / dx) = d/dx_v (x_v x x_w)/3 = -skew(x_w)/3 (d(a x b)/da = -skew(b)).
    hess->block<3, 3>(0, 3) = -skew(xw) / 3.0;
    hess->block<3, 3>(0, 6) = skew(xv) / 3.0;
    hess->block<3, 3>(3, 6) = -skew(x) / 3.0;
    hess->block<3, 3>(3, 0) = hess->block<3, 3>(0, 3).transpose();
    hess->block<3, 3>(6, 0) = hess->block<3, 3>(0, 6).transpose();
    hess->block<3, 3>(6, 3) = hess->block<3, 3>(3, 6).transpose();
  }
  return v;
}

void add_loop_point_derivatives(const LoopBasis& basis, int first_row, int rows,
                                const Eigen::VectorXd& local_grad,
                                const Eigen::MatrixXd* local_hess, Positions* grad,
                                std::vector<Eigen::Triplet<double>>* hess) {
  const int ns = static_cast<int>(basis.vertices.size());
  if (grad != nullptr)
    for (int k = 0; k < ns; ++k)
      for (int r = 0; r < rows; ++r)
        grad->col(basis.vertices[k]) +=
            basis.shape(first_row + r, k) * local_grad.segment<3>(3 * r);
  if (hess == nullptr || local_hess == nullptr) return;
  for (int k = 0; k < ns; ++k)
    for (int l = 0; l < ns; ++l) {
      Eigen::Matrix3d b = Eigen::Matrix3d::Zero();
      for (int r = 0; r < rows; ++r)
        for (int s = 0; s < rows; ++s)
          b += basis.shape(first_row + r, k) * basis.shape(first_row + s, l) *
               local_hess->block<3, 3>(3 * r, 3 * s);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          hess->emplace_back(3 * basis.vertices[k] + i, 3 * basis.vertices[l] + j, b(i, j));
    }
}

}  // namespace rbc
