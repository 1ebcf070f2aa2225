// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/dissipation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "core/lbfgs.hpp"

namespace rbc {

namespace {

const std::array<Eigen::Matrix2d, 3>& rate_modes() {
  static const std::array<Eigen::Matrix2d, 3> modes = [] {
    std::array<Eigen::Matrix2d, 3> m;
    m[0] << 1, 0, 0, -1;
    m[1] << 0, 1, 1, 0;
    m[2] = Eigen::Matrix2d::Identity();
    return m;
  }();
  return modes;
}

MembraneViscosities from_rates(const std::array<double, 3>& r, double area) {
  MembraneViscosities v;
  v.shear_pN_s_per_um = 0.5 * (r[0] + r[1]) / (2.0 * area);
  v.dilatational_pN_s_per_um = r[2] / (2.0 * area);
  return v;
}

}  // namespace

double network_dissipation_rate(const PeriodicNetwork& net, double gamma, const Eigen::Matrix2Xd& U,
                                const Eigen::Matrix2d& D, const Eigen::Matrix2Xd& V) {
  double r = 0.0;
  for (const PeriodicEdge& e : net.edges) {
    const Eigen::Vector2d d = e.ref + U.col(e.j) - U.col(e.i);
    const double rate = d.normalized().dot(D * d + V.col(e.j) - V.col(e.i));
    r += 0.5 * gamma * rate * rate;
  }
  return r;
}

MembraneViscosities affine_viscosities(const PeriodicNetwork& net, double gamma) {
  const Eigen::Matrix2Xd zero = Eigen::Matrix2Xd::Zero(2, net.vertex_count());
  std::array<double, 3> r{};
  for (int k = 0; k < 3; ++k)
    r[k] = network_dissipation_rate(net, gamma, zero, rate_modes()[k], zero);
  return from_rates(r, net.reference_area_um2());
}

void QuasiStaticOptions::validate() const {
  if (!(strain_step > 0) || !(strain_step < 0.1))
    throw std::invalid_argument("quasi-static strain step must be in (0, 0.1), got " +
                                std::to_string(strain_step));
}

QuasiStaticViscosities quasi_static_viscosities(const PeriodicNetwork& net,
                                                const NetworkMaterial& m, double gamma,
                                                const QuasiStaticOptions& o) {
  o.validate();
  if (!(gamma > 0))
    throw std::invalid_argument("link damping gamma must be > 0 pN s/um, got " +
                                std::to_string(gamma));
  QuasiStaticViscosities out;
  out.converged = true;
  const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
  const CellRelaxResult base = relax_patch(net, m, I, {}, o.relax);
  out.converged = base.converged();
  out.largest_residual_pN = base.residual_pN;
  const Eigen::Matrix2Xd zero = Eigen::Matrix2Xd::Zero(2, net.vertex_count());
  std::array<double, 3> r{}, ra{};
  const double h = o.strain_step;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Matrix2d& D = rate_modes()[k];
    const CellRelaxResult plus = relax_patch(net, m, I + h * D, base.U, o.relax);
    const CellRelaxResult minus = relax_patch(net, m, I - h * D, base.U, o.relax);
    out.converged = out.converged && plus.converged() && minus.converged();
    out.largest_residual_pN =
        std::max({out.largest_residual_pN, plus.residual_pN, minus.residual_pN});
    const Eigen::Matrix2Xd V = (plus.U - minus.U) / (2.0 * h);
    r[k] = network_dissipation_rate(net, gamma, base.U, D, V);
    ra[k] = network_dissipation_rate(net, gamma, base.U, D, zero);
  }
  out.viscosities = from_rates(r, net.reference_area_um2());
  out.affine = from_rates(ra, net.reference_area_um2());
  return out;
}

bool periodic_patch_step(const PeriodicNetwork& net, const NetworkMaterial& m, double gamma,
                         double dt, PatchState& s, double force_tolerance) {
  const int n = net.vertex_count();
  if (s.U.cols() != n) s.U = Eigen::Matrix2Xd::Zero(2, n);
  // Previous link lengths.
  Eigen::VectorXd lprev(net.edges.size());
  for (size_t e = 0; e < net.edges.size(); ++e) {
    const PeriodicEdge& ed = net.edges[e];
    lprev(e) = (s.F * ed.ref + s.U.col(ed.j) - s.U.col(ed.i)).norm();
  }
  const double c = gamma / dt;
  // Unknowns: (F00, F01 = F10, F11) then u_1..u_{N-1}; u_0 = 0 pins translations.
  auto unpack = [&](const Eigen::VectorXd& v, Eigen::Matrix2d& F, Eigen::Matrix2Xd& U) {
    F << v(0), v(1), v(1), v(2);
    U = Eigen::Matrix2Xd::Zero(2, n);
    for (int k = 1; k < n; ++k) U.col(k) = v.segment<2>(3 + 2 * (k - 1));
  };
  const Objective f = [&](const Eigen::VectorXd& v, Eigen::VectorXd& g) {
    Eigen::Matrix2d F;
    Eigen::Matrix2Xd U;
    unpack(v, F, U);
    if (!(F.determinant() > 0)) return std::numeric_limits<double>::infinity();
    Eigen::Matrix2Xd gu;
    Eigen::Matrix2d gf;
    double e = patch_energy(net, m, F, U, &gu, &gf);
    if (!std::isfinite(e)) return e;
    for (size_t k = 0; k < net.edges.size(); ++k) {
      const PeriodicEdge& ed = net.edges[k];
      const Eigen::Vector2d d = F * ed.ref + U.col(ed.j) - U.col(ed.i);
      const double l = d.norm(), dl = l - lprev(k);
      e += 0.5 * c * dl * dl;
      const Eigen::Vector2d gd = c * dl * d / l;
      gu.col(ed.j) += gd;
      gu.col(ed.i) -= gd;
      gf += gd * ed.ref.transpose();
    }
    g.resize(v.size());
    g(0) = gf(0, 0);
    g(1) = gf(0, 1) + gf(1, 0);
    g(2) = gf(1, 1);
    for (int k = 1; k < n; ++k) g.segment<2>(3 + 2 * (k - 1)) = gu.col(k);
    return e;
  };
  Eigen::VectorXd v(3 + 2 * (n - 1));
  v(0) = s.F(0, 0);
  v(1) = 0.5 * (s.F(0, 1) + s.F(1, 0));
  v(2) = s.F(1, 1);
  for (int k = 1; k < n; ++k) v.segment<2>(3 + 2 * (k - 1)) = s.U.col(k) - s.U.col(0);
  // Newton's method on the stationarity condition with the Jacobian by central
  // differences of the analytic gradient (a few dozen unknowns; the step is nearly
  // quadratic for the small strains it is used at, and energy differences at the solver's
  // tolerance are far below the round-off of E, so no energy line search is used).
  auto gradient = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd g;
    const double e = f(y, g);
    if (!std::isfinite(e)) g = Eigen::VectorXd::Constant(y.size(), std::nan(""));
    return g;
  };
  Eigen::VectorXd g = gradient(v);
  bool converged = false;
  for (int iter = 0; iter < 30 && g.allFinite(); ++iter) {
    if (g.cwiseAbs().maxCoeff() < force_tolerance) {
      converged = true;
      break;
    }
    const Eigen::Index nv = v.size();
    Eigen::MatrixXd jac(nv, nv);
    for (Eigen::Index k = 0; k < nv; ++k) {
      const double h = 1e-6 * (k < 3 ? 1.0 : net.box.norm() / std::sqrt(double(n)));
      Eigen::VectorXd vp = v, vm = v;
      vp(k) += h;
      vm(k) -= h;
      jac.col(k) = (gradient(vp) - gradient(vm)) / (2 * h);
    }
    const Eigen::MatrixXd sym = 0.5 * (jac + jac.transpose());
    v -= sym.ldlt().solve(g);
    g = gradient(v);
  }
  if (!converged && g.allFinite()) converged = g.cwiseAbs().maxCoeff() < force_tolerance;
  unpack(v, s.F, s.U);
  return converged;
}

}  // namespace rbc
