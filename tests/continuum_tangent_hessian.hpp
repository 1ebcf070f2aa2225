// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The constrained Hessian of a continuum equilibrium on its tangent space, dense: an
// independent stability check for tests (strict minimum or saddle) and the implicit-function
// response of an equilibrium. Dense, so for meshes of a few hundred vertices only.
#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include "continuum/block_hessian.hpp"
#include "continuum/continuum_model.hpp"
#include "core/geometry.hpp"

namespace rbc::testing {

// The Lagrangian Hessian H = d2E + lambda_A d2A + lambda_V d2V (pN/um) at x, dense, restricted
// to the constraints' tangent space {d : dA.d = dV.d = 0} without the motions that cost nothing:
// the three translations and the turn about the load axis x (about every axis at zero force).
// Z' H Z with Z an orthonormal basis of that space (Householder QR of the excluded directions).
struct TangentHessian {
  Eigen::MatrixXd full;  ///< H, 3N x 3N
  Eigen::MatrixXd c;     ///< 3N x 2: dA, dV
  Eigen::MatrixXd z;     ///< 3N x (3N - excluded), orthonormal columns
  Eigen::MatrixXd h;     ///< Z' H Z
};

inline TangentHessian tangent_hessian(const ContinuumModel& m, const Positions& x,
                                      const ConstraintMultipliers& l, double force_pN) {
  BlockHessian bh(m.topo);
  bh.set_zero();
  add_continuum_hessian(m, x, bh);
  add_constraint_hessian(x, m.topo, l.area_pN_per_um, l.volume_pN_per_um2, bh);
  const Eigen::MatrixXd hd = Eigen::MatrixXd(bh.matrix());
  const ConstraintValues c = evaluate_constraints(x, m.topo);
  const Eigen::Index n = hd.rows();
  const int turns = force_pN > 0 ? 1 : 3;
  Eigen::MatrixXd excluded = Eigen::MatrixXd::Zero(n, 5 + turns);
  excluded.col(0) = flat(c.grad_area);
  excluded.col(1) = flat(c.grad_volume);
  const Eigen::Vector3d centre = x.rowwise().mean();
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    for (int a = 0; a < 3; ++a) excluded(3 * i + a, 2 + a) = 1.0;
    for (int a = 0; a < turns; ++a)
      excluded.block<3, 1>(3 * i, 5 + a) = Eigen::Vector3d::Unit(a).cross(x.col(i) - centre);
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(excluded);
  TangentHessian t;
  t.full = hd;
  t.c = excluded.leftCols(2);
  t.z = (qr.householderQ() * Eigen::MatrixXd::Identity(n, n)).rightCols(n - excluded.cols());
  t.h = t.z.transpose() * hd * t.z;
  return t;
}

// Its smallest eigenvalue (pN/um), by Eigen's dense symmetric eigensolver: positive at a strict
// constrained minimum, negative at a saddle. Independent of the mirror-sector Cholesky inertia
// the forward model's stability check uses (core/symmetry_stability.hpp).
inline double smallest_tangent_eigenvalue(const TangentHessian& t) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(t.h, Eigen::EigenvaluesOnly)
      .eigenvalues()(0);
}

}  // namespace rbc::testing
