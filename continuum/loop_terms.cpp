// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/loop_terms.hpp"

#include <cmath>
#include <limits>

#include "continuum/membrane_element.hpp"
#include "core/validation.hpp"

namespace rbc {

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
  const Eigen::Matrix2d& gi = ref.metric_inverse;
  const double jbar = ref.jacobian_um2;
  const double i2 = gi(0, 0) * xv.dot(xv) + 2 * gi(0, 1) * xv.dot(xw) + gi(1, 1) * xw.dot(xw) - 2;
  Vector6d dj;
  Matrix6d d2j;
  const bool derivatives = grad != nullptr || hess != nullptr;
  const double j =
      loop_area_density(xv, xw, derivatives ? &dj : nullptr, derivatives ? &d2j : nullptr);
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

double loop_cross_norm2(const Vec3& xv, const Vec3& xw, Vector6d* grad, Matrix6d* hess) {
  const Vec3 m = xv.cross(xw);
  if (grad != nullptr) {
    grad->head<3>() = 2 * xw.cross(m);
    grad->tail<3>() = 2 * m.cross(xv);
  }
  if (hess != nullptr) {
    const Eigen::Matrix3d ma = -cross_matrix(xw), mb = cross_matrix(xv);
    hess->block<3, 3>(0, 0) = 2 * ma.transpose() * ma;
    hess->block<3, 3>(3, 3) = 2 * mb.transpose() * mb;
    hess->block<3, 3>(0, 3) = 2 * ma.transpose() * mb - 2 * cross_matrix(m);
    hess->block<3, 3>(3, 0) = hess->block<3, 3>(0, 3).transpose();
  }
  return m.squaredNorm();
}

double loop_area_density(const Vec3& xv, const Vec3& xw, Vector6d* grad, Matrix6d* hess) {
  // J = sqrt(J^2): dJ = dJ^2 / (2J), d2J = d2J^2 / (2J) - dJ^2 dJ^2' / (4 J^3).
  Vector6d g2;
  Matrix6d h2;
  const bool derivatives = grad != nullptr || hess != nullptr;
  const double j = std::sqrt(
      loop_cross_norm2(xv, xw, derivatives ? &g2 : nullptr, hess != nullptr ? &h2 : nullptr));
  if (grad != nullptr) *grad = g2 / (2 * j);
  if (hess != nullptr) *hess = h2 / (2 * j) - g2 * g2.transpose() / (4 * j * j * j);
  return j;
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
    const auto skew = [](const Vec3& a) { return cross_matrix(a); };
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
