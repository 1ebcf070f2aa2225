// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/membrane_element.hpp"

#include "discrete/element_hessian.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rbc {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

using Edge6 = Eigen::Matrix<double, 6, 1>;
using Edge66 = Eigen::Matrix<double, 6, 6>;

/// Maps an edge-variable gradient (de1, de2) to vertex variables (x0, x1, x2):
/// e1 = x1 - x0, e2 = x2 - x0.
ElementGradient edge_to_vertex(const Edge6& g) {
  ElementGradient out;
  out.segment<3>(0) = -g.segment<3>(0) - g.segment<3>(3);
  out.segment<3>(3) = g.segment<3>(0);
  out.segment<3>(6) = g.segment<3>(3);
  return out;
}

/// B^T H B with B the 6 x 9 edge-from-vertex map.
ElementHessian edge_to_vertex(const Edge66& h) {
  Eigen::Matrix<double, 6, 9> b = Eigen::Matrix<double, 6, 9>::Zero();
  b.block<3, 3>(0, 0) = -Eigen::Matrix3d::Identity();
  b.block<3, 3>(0, 3) = Eigen::Matrix3d::Identity();
  b.block<3, 3>(3, 0) = -Eigen::Matrix3d::Identity();
  b.block<3, 3>(3, 6) = Eigen::Matrix3d::Identity();
  return b.transpose() * h * b;
}

/// Current metric g_ab = e_a . e_b.
Eigen::Matrix2d current_metric(const Vec3& e1, const Vec3& e2) {
  Eigen::Matrix2d g;
  g << e1.squaredNorm(), e1.dot(e2), e1.dot(e2), e2.squaredNorm();
  return g;
}

}  // namespace

MembraneReference make_membrane_reference(const Vec3& x0, const Vec3& x1, const Vec3& x2) {
  const Eigen::Matrix2d metric = current_metric(x1 - x0, x2 - x0);
  const double det = metric.determinant();
  if (!(det > 0) || !std::isfinite(det))
    throw std::invalid_argument("membrane element reference triangle is degenerate (area^2 = " +
                                std::to_string(det / 4) + " um^4); expected a positive area");
  MembraneReference ref;
  ref.metric_inverse = metric.inverse();
  ref.area_um2 = 0.5 * std::sqrt(det);
  return ref;
}

SurfaceInvariants surface_invariants(const MembraneReference& ref, const Vec3& x0, const Vec3& x1,
                                     const Vec3& x2) {
  const Eigen::Matrix2d g = current_metric(x1 - x0, x2 - x0);
  SurfaceInvariants inv;
  inv.i2 = (ref.metric_inverse * g).trace() - 2.0;
  inv.i1 = 0.5 * std::sqrt(std::max(g.determinant(), 0.0)) / ref.area_um2 - 1.0;
  return inv;
}

namespace {

/// The element's energy with its gradient and the Hessian's parts d2E = rest + coef d2A
/// (coef = Psi_1 in pN/um: the term Abar Psi_1 d2J with d2J = d2A / Abar).
double membrane_element_parts(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                              const Vec3& x0, const Vec3& x1, const Vec3& x2, ElementGradient* grad,
                              ElementHessian* rest, double* area_coef) {
  const Vec3 e1 = x1 - x0, e2 = x2 - x0;
  const Eigen::Matrix2d& gi = ref.metric_inverse;
  const double g11 = e1.squaredNorm(), g12 = e1.dot(e2), g22 = e2.squaredNorm();
  const double det = g11 * g22 - g12 * g12;  // (2A)^2
  const double sq = std::sqrt(std::max(det, 0.0));
  const double jac = 0.5 * sq / ref.area_um2;
  if (!(jac >= kCollapsedElementRatio)) return kInf;
  const double i2 = gi(0, 0) * g11 + 2.0 * gi(0, 1) * g12 + gi(1, 1) * g22 - 2.0;
  const InvariantDerivatives d = law.evaluate(jac - 1.0, i2);
  if (!std::isfinite(d.psi)) return kInf;
  if (!grad && !rest) return ref.area_um2 * d.psi;

  // dJ, d2J from the area derivatives (J = A/Abar); I2 in edge variables (e1, e2), whose
  // Hessian 2 G^-1 (x) I3 is constant.
  Vector9d dA;
  triangle_area_hessian(x0, x1, x2, &dA, nullptr);
  const ElementGradient dJ = dA / ref.area_um2;
  Edge6 dI2e;
  dI2e.segment<3>(0) = 2.0 * (gi(0, 0) * e1 + gi(0, 1) * e2);
  dI2e.segment<3>(3) = 2.0 * (gi(1, 0) * e1 + gi(1, 1) * e2);
  const ElementGradient dI2 = edge_to_vertex(dI2e);
  if (grad) *grad = ref.area_um2 * (d.d1 * dJ + d.d2 * dI2);
  if (rest) {
    Edge66 d2I2e;
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)
        d2I2e.block<3, 3>(3 * a, 3 * b) = 2.0 * gi(a, b) * Eigen::Matrix3d::Identity();
    *rest = ref.area_um2 * (d.d11 * dJ * dJ.transpose() +
                            d.d12 * (dJ * dI2.transpose() + dI2 * dJ.transpose()) +
                            d.d22 * dI2 * dI2.transpose()) +
            ref.area_um2 * d.d2 * edge_to_vertex(d2I2e);
    *area_coef = d.d1;
  }
  return ref.area_um2 * d.psi;
}

}  // namespace

double membrane_element_energy(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                               const Vec3& x0, const Vec3& x1, const Vec3& x2,
                               ElementGradient* grad, ElementHessian* hess) {
  double coef = 0.0;
  const double e = membrane_element_parts(law, ref, x0, x1, x2, grad, hess, &coef);
  if (hess && std::isfinite(e)) {
    Matrix9d d2A;
    triangle_area_hessian(x0, x1, x2, nullptr, &d2A);
    *hess += coef * d2A;
  }
  return e;
}

double membrane_element_hessian_parts(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                                      const Vec3& x0, const Vec3& x1, const Vec3& x2,
                                      ElementHessian& rest, double& area_coef) {
  return membrane_element_parts(law, ref, x0, x1, x2, nullptr, &rest, &area_coef);
}

PrincipalTensions principal_tensions(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                                     const Vec3& x0, const Vec3& x1, const Vec3& x2) {
  const Eigen::Matrix2d c = ref.metric_inverse * current_metric(x1 - x0, x2 - x0);
  // Eigenvalues of the (non-symmetric but similar-to-symmetric) 2 x 2 matrix G^-1 g.
  const double tr = c.trace(), det = std::max(c.determinant(), 0.0);
  const double disc = std::sqrt(std::max(0.25 * tr * tr - det, 0.0));
  const double l1 = 0.5 * tr + disc, l2 = 0.5 * tr - disc;
  const double jac = std::sqrt(det);
  PrincipalTensions t;
  if (!(jac >= kCollapsedElementRatio)) {
    t.t1 = t.t2 = kInf;
    return t;
  }
  const InvariantDerivatives d = law.evaluate(jac - 1.0, tr - 2.0);
  if (!std::isfinite(d.psi)) {
    t.t1 = t.t2 = kInf;
    return t;
  }
  t.t1 = 2.0 * d.d2 * l1 / jac + d.d1;
  t.t2 = 2.0 * d.d2 * l2 / jac + d.d1;
  if (t.t2 > t.t1) std::swap(t.t1, t.t2);
  return t;
}

}  // namespace rbc
