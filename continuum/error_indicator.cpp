// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/error_indicator.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace rbc {

namespace {

/// The smallest rotation taking unit vector a to unit vector b (Rodrigues); for a = -b (not
/// met between neighbouring faces of a surface) the reflection-free half-turn about any
/// axis normal to a.
Eigen::Matrix3d rotation_between(const Vec3& a, const Vec3& b) {
  const Vec3 k = a.cross(b);
  const double c = a.dot(b);
  if (c < -1.0 + 1e-12) {
    const Vec3 axis =
        (std::abs(a.x()) < 0.9 ? a.cross(Vec3::UnitX()) : a.cross(Vec3::UnitY())).normalized();
    return 2.0 * axis * axis.transpose() - Eigen::Matrix3d::Identity();
  }
  Eigen::Matrix3d kx;
  kx << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  return Eigen::Matrix3d::Identity() + kx + kx * kx / (1.0 + c);
}

}  // namespace

Eigen::Matrix3d element_stress_tensor(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                                      const Vec3& x0, const Vec3& x1, const Vec3& x2) {
  const Vec3 e1 = x1 - x0, e2 = x2 - x0;
  const Vec3 cross = e1.cross(e2);
  const double jac = 0.5 * cross.norm() / ref.area_um2;
  const double inf = std::numeric_limits<double>::infinity();
  if (!(jac >= kCollapsedElementRatio)) return Eigen::Matrix3d::Constant(inf);
  const Eigen::Matrix2d& gi = ref.metric_inverse;
  const Eigen::Matrix3d b = gi(0, 0) * e1 * e1.transpose() + gi(1, 1) * e2 * e2.transpose() +
                            gi(0, 1) * (e1 * e2.transpose() + e2 * e1.transpose());
  const Eigen::Matrix2d g =
      (Eigen::Matrix2d() << e1.dot(e1), e1.dot(e2), e1.dot(e2), e2.dot(e2)).finished();
  const double i2 = (gi * g).trace() - 2.0;
  const InvariantDerivatives d = law.evaluate(jac - 1.0, i2);
  if (!std::isfinite(d.psi)) return Eigen::Matrix3d::Constant(inf);
  const Vec3 n = cross.normalized();
  const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - n * n.transpose();
  return 2.0 * d.d2 / jac * b + d.d1 * p;
}

Eigen::VectorXd recovery_error_indicator(const Positions& x, const Faces& faces,
                                         const std::vector<Eigen::Matrix3d>& stress) {
  const Eigen::Index nf = faces.cols(), nv = x.cols();
  if (static_cast<Eigen::Index>(stress.size()) != nf)
    throw std::invalid_argument("recovery_error_indicator: " + std::to_string(stress.size()) +
                                " stresses for " + std::to_string(nf) + " faces");
  if (nf > 0 && (faces.minCoeff() < 0 || faces.maxCoeff() >= nv))
    throw std::invalid_argument("recovery_error_indicator: a face index is not a vertex");
  std::vector<Vec3> face_normal(static_cast<size_t>(nf));
  Eigen::VectorXd face_area(nf);
  Positions vertex_normal = Positions::Zero(3, nv);
  for (Eigen::Index f = 0; f < nf; ++f) {
    const Vec3 c =
        (x.col(faces(1, f)) - x.col(faces(0, f))).cross(x.col(faces(2, f)) - x.col(faces(0, f)));
    face_area(f) = 0.5 * c.norm();
    face_normal[static_cast<size_t>(f)] = c.normalized();
    for (int k = 0; k < 3; ++k) vertex_normal.col(faces(k, f)) += c;  // area-weighted
  }
  for (Eigen::Index v = 0; v < nv; ++v) {
    const double len = vertex_normal.col(v).norm();
    if (len > 0) vertex_normal.col(v) /= len;
  }
  // Recovered nodal stresses in the vertices' tangent planes.
  std::vector<Eigen::Matrix3d> recovered(static_cast<size_t>(nv), Eigen::Matrix3d::Zero());
  Eigen::VectorXd weight = Eigen::VectorXd::Zero(nv);
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = faces(k, f);
      const Eigen::Matrix3d r =
          rotation_between(face_normal[static_cast<size_t>(f)], vertex_normal.col(v));
      recovered[static_cast<size_t>(v)] +=
          face_area(f) * r * stress[static_cast<size_t>(f)] * r.transpose();
      weight(v) += face_area(f);
    }
  for (Eigen::Index v = 0; v < nv; ++v)
    if (weight(v) > 0) recovered[static_cast<size_t>(v)] /= weight(v);
  Eigen::VectorXd eta(nf);
  for (Eigen::Index f = 0; f < nf; ++f) {
    Eigen::Matrix3d d[3];
    for (int k = 0; k < 3; ++k) {
      const int v = faces(k, f);
      const Eigen::Matrix3d r =
          rotation_between(vertex_normal.col(v), face_normal[static_cast<size_t>(f)]);
      d[k] = r * recovered[static_cast<size_t>(v)] * r.transpose() - stress[static_cast<size_t>(f)];
    }
    const double sq = d[0].squaredNorm() + d[1].squaredNorm() + d[2].squaredNorm() +
                      (d[0] + d[1] + d[2]).squaredNorm();
    eta(f) = std::sqrt(face_area(f) / 12.0 * sq);
  }
  return eta;
}

Eigen::VectorXd error_indicator(const ContinuumModel& model, const Positions& x) {
  const int nf = model.num_elements();
  if (!model.inplane()) return Eigen::VectorXd::Zero(nf);
  std::vector<Eigen::Matrix3d> stress(static_cast<size_t>(nf));
  for (int f = 0; f < nf; ++f) {
    const auto t = model.topo.faces.col(f);
    stress[static_cast<size_t>(f)] =
        element_stress_tensor(model.law, model.reference[f], x.col(t(0)), x.col(t(1)), x.col(t(2)));
  }
  return recovery_error_indicator(x, model.topo.faces, stress);
}

}  // namespace rbc
