// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/loop_bending.hpp"

#include <cmath>
#include <limits>
#include <unsupported/Eigen/AutoDiff>

#include "continuum/loop_terms.hpp"

namespace rbc {

namespace loop_bending_internal {

using Ad1 = Eigen::AutoDiffScalar<Eigen::Matrix<double, 15, 1>>;
using Ad2 = Eigen::AutoDiffScalar<Eigen::Matrix<Ad1, 15, 1>>;

// e = (kappa/2) (H - H0)^2 J over the 15 jet components z (see the header), any scalar type.
template <class T>
T helfrich_density(const std::array<T, 15>& z, double kappa, double h0) {
  auto dot = [&](int i, int j) {
    return z[3 * i] * z[3 * j] + z[3 * i + 1] * z[3 * j + 1] + z[3 * i + 2] * z[3 * j + 2];
  };
  // m = x_v x x_w (not normalised), J = |m|.
  const T m0 = z[1] * z[5] - z[2] * z[4];
  const T m1 = z[2] * z[3] - z[0] * z[5];
  const T m2 = z[0] * z[4] - z[1] * z[3];
  const T j2 = m0 * m0 + m1 * m1 + m2 * m2;
  using std::sqrt;
  const T j = sqrt(j2);
  auto bm = [&](int i) { return z[3 * i] * m0 + z[3 * i + 1] * m1 + z[3 * i + 2] * m2; };
  // b_ab J = x_ab . m; H = -(g_ww b_vv - 2 g_vw b_vw + g_vv b_ww) / J^2.
  const T num = dot(1, 1) * bm(2) - 2.0 * dot(0, 1) * bm(3) + dot(0, 0) * bm(4);
  const T hm = -num / (j2 * j) - h0;
  return 0.5 * kappa * hm * hm * j;
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
  if (jet[0].cross(jet[1]).squaredNorm() == 0.0) return std::numeric_limits<double>::infinity();
  const double kappa = params.kappa_pNum, h0 = params.h0_per_um;
  std::array<double, 15> z{};
  for (int i = 0; i < 15; ++i) z[i] = jet[i / 3](i % 3);
  if (hess != nullptr) {
    std::array<loop_bending_internal::Ad2, 15> zz;
    for (int i = 0; i < 15; ++i) {
      zz[i].value() = loop_bending_internal::Ad1(z[i], 15, i);
      zz[i].derivatives().setZero();
      zz[i].derivatives()(i) = loop_bending_internal::Ad1(1.0);
    }
    const loop_bending_internal::Ad2 e = loop_bending_internal::helfrich_density(zz, kappa, h0);
    for (int i = 0; i < 15; ++i) {
      if (grad != nullptr) (*grad)(i) = e.derivatives()(i).value();
      for (int k = 0; k < 15; ++k) (*hess)(i, k) = e.derivatives()(i).derivatives()(k);
    }
    return e.value().value();
  }
  if (grad != nullptr) {
    std::array<loop_bending_internal::Ad1, 15> zz;
    for (int i = 0; i < 15; ++i) zz[i] = loop_bending_internal::Ad1(z[i], 15, i);
    const loop_bending_internal::Ad1 e = loop_bending_internal::helfrich_density(zz, kappa, h0);
    *grad = e.derivatives();
    return e.value();
  }
  return loop_bending_internal::helfrich_density(z, kappa, h0);
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
