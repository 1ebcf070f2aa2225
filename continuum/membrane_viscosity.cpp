// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/membrane_viscosity.hpp"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rbc {

void MembraneViscosity::validate() const {
  if (!(shear_pN_s_per_um > 0) || !std::isfinite(shear_pN_s_per_um))
    throw std::invalid_argument("membrane shear viscosity must be finite and > 0 pN s/um, got " +
                                std::to_string(shear_pN_s_per_um));
  if (!(dilatational_pN_s_per_um >= 0) || !std::isfinite(dilatational_pN_s_per_um))
    throw std::invalid_argument(
        "membrane dilatational viscosity must be finite and >= 0 pN s/um, got " +
        std::to_string(dilatational_pN_s_per_um));
  if (!(dt_s > 0) || !std::isfinite(dt_s))
    throw std::invalid_argument("time step must be finite and > 0 s, got " + std::to_string(dt_s));
}

double membrane_viscosity_element(const MembraneViscosity& p, const MembraneReference& prev,
                                  const Vec3& x0, const Vec3& x1, const Vec3& x2,
                                  Eigen::Matrix<double, 9, 1>* grad,
                                  Eigen::Matrix<double, 9, 9>* hess) {
  const std::array<Vec3, 2> e{x1 - x0, x2 - x0};
  Eigen::Matrix2d g;
  g << e[0].squaredNorm(), e[0].dot(e[1]), e[0].dot(e[1]), e[1].squaredNorm();
  const Eigen::Matrix2d& pm = prev.metric_inverse;
  const double c0 = prev.area_um2 / p.dt_s;
  const double em = p.shear_pN_s_per_um, ed = p.dilatational_pN_s_per_um;
  const Eigen::Matrix2d a = pm * g - Eigen::Matrix2d::Identity();  // 2 M
  const double t = a.trace();
  const double q = (a * a).trace();
  const double value = c0 * (0.25 * em * q + 0.125 * (ed - em) * t * t);
  if (!grad && !hess) return value;
  const Eigen::Matrix2d gg = c0 * (0.5 * em * (pm * g * pm - pm) + 0.25 * (ed - em) * t * pm);
  Eigen::Matrix<double, 6, 1> ge;
  for (int i = 0; i < 2; ++i) ge.segment<3>(3 * i) = 2.0 * (gg(i, 0) * e[0] + gg(i, 1) * e[1]);
  // Vertex map: x0 -> -(e1 + e2), x1 -> e1, x2 -> e2.
  Eigen::Matrix<double, 6, 9> b = Eigen::Matrix<double, 6, 9>::Zero();
  b.block<3, 3>(0, 0) = -Eigen::Matrix3d::Identity();
  b.block<3, 3>(0, 3) = Eigen::Matrix3d::Identity();
  b.block<3, 3>(3, 0) = -Eigen::Matrix3d::Identity();
  b.block<3, 3>(3, 6) = Eigen::Matrix3d::Identity();
  if (grad) *grad = b.transpose() * ge;
  if (hess) {
    // dg for each edge dof (k, alpha): dg_ij = delta_ik e_j[alpha] + delta_jk e_i[alpha].
    std::array<Eigen::Matrix2d, 6> dg;
    std::array<Eigen::Matrix2d, 6> pdg;
    for (int k = 0; k < 2; ++k)
      for (int al = 0; al < 3; ++al) {
        Eigen::Matrix2d m = Eigen::Matrix2d::Zero();
        for (int i = 0; i < 2; ++i)
          for (int j = 0; j < 2; ++j)
            m(i, j) = (i == k ? e[j](al) : 0.0) + (j == k ? e[i](al) : 0.0);
        dg[3 * k + al] = m;
        pdg[3 * k + al] = pm * m;
      }
    Eigen::Matrix<double, 6, 6> he;
    for (int r = 0; r < 6; ++r)
      for (int s = r; s < 6; ++s) {
        const double v = c0 * (0.5 * em * (pdg[r] * pdg[s]).trace() +
                               0.25 * (ed - em) * pdg[r].trace() * pdg[s].trace());
        he(r, s) = he(s, r) = v;
      }
    for (int k = 0; k < 2; ++k)
      for (int l = 0; l < 2; ++l)
        he.block<3, 3>(3 * k, 3 * l) += 2.0 * gg(k, l) * Eigen::Matrix3d::Identity();
    *hess = b.transpose() * he * b;
  }
  return value;
}

std::vector<MembraneReference> viscous_references(const Positions& x_prev, const Topology& topo) {
  std::vector<MembraneReference> out;
  out.reserve(topo.num_faces());
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto t = topo.faces.col(f);
    out.push_back(make_membrane_reference(x_prev.col(t(0)), x_prev.col(t(1)), x_prev.col(t(2))));
  }
  return out;
}

double membrane_viscosity_energy(const MembraneViscosity& p, const Topology& topo,
                                 const std::vector<MembraneReference>& prev, const Positions& x,
                                 Positions* grad) {
  double total = 0.0;
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto t = topo.faces.col(f);
    Eigen::Matrix<double, 9, 1> g;
    total += membrane_viscosity_element(p, prev[f], x.col(t(0)), x.col(t(1)), x.col(t(2)),
                                        grad ? &g : nullptr);
    if (grad)
      for (int k = 0; k < 3; ++k) grad->col(t(k)) += g.segment<3>(3 * k);
  }
  return total;
}

void add_membrane_viscosity_hessian(const MembraneViscosity& p, const Topology& topo,
                                    const std::vector<MembraneReference>& prev, const Positions& x,
                                    BlockHessian& h) {
  const int nf = topo.num_faces();
  std::vector<Eigen::Matrix<double, 9, 9>> he(nf);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    const auto t = topo.faces.col(f);
    membrane_viscosity_element(p, prev[f], x.col(t(0)), x.col(t(1)), x.col(t(2)), nullptr, &he[f]);
  }
  for (int f = 0; f < nf; ++f) {
    const int verts[3] = {topo.faces(0, f), topo.faces(1, f), topo.faces(2, f)};
    h.add_local<3>(verts, he[f]);
  }
}

}  // namespace rbc
