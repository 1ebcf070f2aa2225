// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Viscous membrane of the continuum model (MODEL.md section 6; Evans and Hochmuth 1976):
// Rayleigh potential of the surface rate of deformation D (symmetric surface velocity
// gradient, 1/s),
//   R(v) = integral [eta_m D_dev : D_dev + eta_d/2 (tr D)^2] dA                [pN um/s],
// viscous tension dR/dD = 2 eta_m D_dev + eta_d tr(D) P, so the linearised membrane is the
// Kelvin-Voigt solid T = 2 mu e_dev + K tr(e) P + 2 eta_m de_dev/dt + eta_d d(tr e)/dt:
// a small pure shear relaxes as exp(-t eta_m^-1 mu), a small dilatation as exp(-t K/eta_d).
//
// Backward Euler (x_{n+1} = argmin E(x) + dt R((x - x_n)/dt)) uses, per linear triangle,
// the Green-Lagrange strain of x relative to the previous step x_n as the strain increment
// (exactly invariant under finite rigid motions of the triangle):
//   M = 1/2 (g_n^-1 g - I)           (mixed components; g, g_n current and previous edge
//                                     metrics g_ab = e_a . e_b, so tr M^2 = dE : dE),
//   D_e(x; x_n) = dt R ~ (A_n/dt) [eta_m |dev M|^2 + eta_d/2 (tr M)^2]        [pN um],
//   |dev M|^2 = tr M^2 - (tr M)^2 / 2,
// with A_n the element area at x_n: D ~ M/dt and dt * (A_n (eta_m |dev D|^2 + ...)) gives
// the factor A_n/dt; to first order in x - x_n it is the exact dt R of the linear velocity.
// Units: eta_m, eta_d in pN s/um (= Pa s um = uN s/m), A_n in um^2, dt in s.
// Matching the network (homogenise/dissipation.hpp): dashpots gamma on the hexagonal
// lattice give eta_m = sqrt3 gamma/4, eta_d = sqrt3 gamma/2 = 2 eta_m.
#include <Eigen/Core>
#include <vector>

#include "continuum/block_hessian.hpp"
#include "continuum/membrane_element.hpp"
#include "core/mesh.hpp"

namespace rbc {

struct MembraneViscosity {
  double shear_pN_s_per_um = 0.7;         ///< eta_m (pN s/um), > 0; Hochmuth 1979: 0.6-0.8
  double dilatational_pN_s_per_um = 1.4;  ///< eta_d (pN s/um), >= 0; network value 2 eta_m
  double dt_s = 1e-3;                     ///< time step (s), > 0
  void validate() const;                  ///< throws std::invalid_argument naming the value
};

/// Element term D_e (pN um) with prev = make_membrane_reference(x_n triangle) (its metric
/// inverse g_n^-1 and area A_n); gradient (9, pN, vertex-major) and Hessian (9 x 9, pN/um):
///   dD/dg = (A_n/dt) [eta_m/2 (P g P - P) + (eta_d - eta_m)/4 t P],  P = g_n^-1, t = tr(Pg) - 2,
///   dD/de_a = 2 sum_b (dD/dg)_ab e_b, and the Hessian from the bilinear form
///   B(dg, dg') = (A_n/dt)[eta_m/2 tr(P dg P dg') + (eta_d - eta_m)/4 tr(P dg) tr(P dg')]
///   plus 2 (dD/dg)_ab I3 in edge variables (e1 = x1 - x0, e2 = x2 - x0).
double membrane_viscosity_element(const MembraneViscosity& p, const MembraneReference& prev,
                                  const Vec3& x0, const Vec3& x1, const Vec3& x2,
                                  Eigen::Matrix<double, 9, 1>* grad = nullptr,
                                  Eigen::Matrix<double, 9, 9>* hess = nullptr);

/// References of every face of x_n (F): the previous-step state the term is measured from.
std::vector<MembraneReference> viscous_references(const Positions& x_prev, const Topology& topo);

/// Sum over faces (pN um); gradient (3 x N, pN) accumulated into grad when given.
double membrane_viscosity_energy(const MembraneViscosity& p, const Topology& topo,
                                 const std::vector<MembraneReference>& prev, const Positions& x,
                                 Positions* grad = nullptr);
/// Adds the Hessian (pN/um) into h.
void add_membrane_viscosity_hessian(const MembraneViscosity& p, const Topology& topo,
                                    const std::vector<MembraneReference>& prev, const Positions& x,
                                    BlockHessian& h);

}  // namespace rbc
