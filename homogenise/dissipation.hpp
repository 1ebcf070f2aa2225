// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Homogenised dissipation of the spectrin network (MODEL.md section 6): the cell problem for
// the link dashpots (discrete/link_dashpot.hpp), R = sum_links gamma/2 (dL_e/dt)^2, under a
// uniform surface rate of deformation D (1/s), mapped to the membrane's Rayleigh potential
// per area R/A = eta_m D_dev : D_dev + eta_d/2 (tr D)^2 (continuum/membrane_viscosity.hpp):
//   eta_m = R[D = D_s] / (2 A) averaged over the two pure shears D_s = diag(1,-1), [[0,1],[1,0]]
//           (|dev D_s|^2 = 2),
//   eta_d = R[D = I] / (2 A)   ((tr I)^2 / 2 = 2).
// Affine velocities (v_i = D x_i): on the perfect hexagonal lattice, with the three link
// directions 60 degrees apart and sum cos^2(2 theta) = 3/2, this gives exactly
//   eta_m = sqrt3 gamma/4,  eta_d = sqrt3 gamma/2
// (as springs k give mu = sqrt3 k/4, K = sqrt3 k/2), independent of the spacing.
// Quasi-static limit (disordered networks): the internal positions follow the elastic
// cell-problem minimiser U*(F) (homogenise/periodic_network.hpp), so the non-affine
// velocities are dU*/dt = dU*/ds along F = F_0 + s D, evaluated by the central difference
// (U*(F_0 + h D) - U*(F_0 - h D)) / 2h (error O(h^2)), and R is evaluated on them.
// Units: gamma in pN s/um, viscosities in pN s/um (= Pa s um).
#include <Eigen/Core>

#include "homogenise/periodic_network.hpp"

namespace rbc {

/// Two-dimensional isotropic membrane viscosities (pN s/um).
struct MembraneViscosities {
  double shear_pN_s_per_um = 0.0;         ///< eta_m
  double dilatational_pN_s_per_um = 0.0;  ///< eta_d
};

/// R (pN um/s) of the dashpot network for the vertex velocities v (2 x N, um/s) and the box
/// rate D (1/s) at the configuration x_i = X_i + U_i (F = I): link rate
///   dL_e/dt = u_e . (D d_e + v_j - v_i),  d_e = D_e + U_j - U_i,  u_e = d_e/|d_e|.
double network_dissipation_rate(const PeriodicNetwork& net, double gamma_pN_s_per_um,
                                const Eigen::Matrix2Xd& U, const Eigen::Matrix2d& D,
                                const Eigen::Matrix2Xd& V);

/// Affine velocities on the reference (U = 0, v_i = 0 relative to the box: the whole
/// velocity field is D x).
MembraneViscosities affine_viscosities(const PeriodicNetwork& net, double gamma_pN_s_per_um);

struct QuasiStaticOptions {
  double strain_step = 1e-5;  ///< h of the central difference of U*(F), dimensionless, > 0
  RelaxOptions relax;         ///< elastic cell problem at F = I and F = I +- h D
  void validate() const;
};

/// Result of the quasi-static cell problem.
struct QuasiStaticViscosities {
  MembraneViscosities viscosities;
  MembraneViscosities affine;  ///< affine velocities at the same relaxed configuration
  double largest_residual_pN = 0.0;
  bool converged = false;  ///< every elastic relaxation converged
};

/// Non-affine velocities from the elastic minimiser: relaxes U at F = I (from the affine
/// map), then at I +- h D for the three rate modes, and evaluates R on the velocities.
QuasiStaticViscosities quasi_static_viscosities(const PeriodicNetwork& net,
                                                const NetworkMaterial& m, double gamma_pN_s_per_um,
                                                const QuasiStaticOptions& options = {});

/// One backward-Euler step of the periodic patch with free (symmetric) box deformation F
/// and internal displacements U (vertex 0 pinned), under link dashpots gamma and no load:
///   (F, U)_{n+1} = argmin E(F, U) + gamma/(2 dt) sum_e (L_e - L_e^n)^2.
/// F is kept symmetric (its rotation costs nothing in either term). Solved by Newton's
/// method with a finite-difference Jacobian of the analytic gradient (small patches only).
/// Returns false unless every gradient entry (pN for U, pN um for F) is below
/// force_tolerance_pN.
struct PatchState {
  Eigen::Matrix2d F = Eigen::Matrix2d::Identity();
  Eigen::Matrix2Xd U;  ///< 2 x N (um)
};
bool periodic_patch_step(const PeriodicNetwork& net, const NetworkMaterial& m,
                         double gamma_pN_s_per_um, double dt_s, PatchState& state,
                         double force_tolerance_pN = 1e-11);

}  // namespace rbc
