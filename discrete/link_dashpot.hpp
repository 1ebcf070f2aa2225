// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Link dashpots of the discrete network (MODEL.md section 6): a dashpot in parallel with
// every spectrin link, force gamma dL/dt along the link, Rayleigh potential
//   R(v) = sum_links gamma/2 (dL_e/dt)^2                                  [pN um/s].
// Backward Euler ("minimising movement", x_{n+1} = argmin E(x) + dt R((x - x_n)/dt)) uses
// the discrete incremental potential with dL_e/dt ~ (L_e - L_e^n)/dt,
//   D(x; x_n) = dt R = gamma/(2 dt) sum_e (L_e - L_e^n)^2                  [pN um],
// which depends on link lengths only, so a finite rigid motion of the network costs nothing.
// Units: gamma in pN s/um (force per link-length rate), dt in s.
// Homogenised (hexagonal lattice, as springs k give mu = sqrt3 k/4, K = sqrt3 k/2):
//   eta_m = sqrt3 gamma/4,  eta_d = sqrt3 gamma/2   (homogenise/dissipation.hpp).
#include <Eigen/Core>

#include "core/mesh.hpp"

namespace rbc {

/// Damping of every link and the time step.
struct LinkDashpotParameters {
  double gamma_pN_s_per_um = 1.0;  ///< link damping coefficient (pN s/um), > 0
  double dt_s = 1e-3;              ///< time step (s), > 0
  void validate() const;           ///< throws std::invalid_argument naming the value
};

/// gamma = 4 eta_m / sqrt3: the damping whose hexagonal lattice has shear viscosity eta_m
/// (pN s/um).
double link_damping_for_shear_viscosity(double eta_m_pN_s_per_um);

/// One link (a, b) with length L^n at the previous step (um):
///   D = gamma/(2 dt) (L - L^n)^2,  L = |b - a|                                 [pN um]
///   dD/db = gamma/dt (L - L^n) u = -dD/da,  u = (b - a)/L                      [pN]
///   d2D/db2 = gamma/dt [u u^T + (1 - L^n/L)(I - u u^T)]                        [pN/um]
inline double link_dashpot_energy(double c_pN_per_um, double length_prev_um,
                                  const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                  Eigen::Vector3d* grad_b = nullptr,
                                  Eigen::Matrix3d* hess_bb = nullptr) {
  const Eigen::Vector3d d = b - a;
  const double l = d.norm();
  const double dl = l - length_prev_um;
  const Eigen::Vector3d u = d / l;
  if (grad_b) *grad_b = c_pN_per_um * dl * u;
  if (hess_bb)
    *hess_bb = c_pN_per_um *
               (u * u.transpose() + (dl / l) * (Eigen::Matrix3d::Identity() - u * u.transpose()));
  return 0.5 * c_pN_per_um * dl * dl;
}

/// Link lengths of x (um), one per edge of topo (E).
Eigen::VectorXd link_lengths(const Positions& x, const Topology& topo);

/// D(x; x_n) = gamma/(2 dt) sum_e (L_e - L_e^n)^2 over the edges of topo (pN um), with
/// lengths_prev = link_lengths(x_n) (E). grad (3 x N, pN) is accumulated into when given.
double link_dashpot_energy(const LinkDashpotParameters& p, const Topology& topo,
                           const Eigen::VectorXd& lengths_prev_um, const Positions& x,
                           Positions* grad = nullptr);

}  // namespace rbc
