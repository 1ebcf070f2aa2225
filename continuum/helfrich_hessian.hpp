#pragma once
// Newton Hessian of the Canham-Helfrich energy in Juelicher's discretisation, the operator
// shared with discrete/ (discrete/bending_energy.hpp juelicher_bending_energy gives value
// and gradient; this adds the second derivative).
//
// E = (kappa/2) sum_v g(M_v, A_v),  g = (M - H0 A)^2 / A,  h = (M - H0 A)/A,
// M_v = 1/2 sum_{e ni v} q_e (q_e = L_e theta_e),  A_v = 1/3 sum_{f ni v} A_f. Since
// g_MM g_AA = g_MA^2 the (M, A) quadratic form is rank one, and
//   d2E = sum_v (kappa/A_v) u_v u_v^T,  u_v = dM_v - (H0 + h_v) dA_v
//       + sum_e (kappa/2)(h_a + h_b) d2q_e  -  sum_f (kappa/3) sum_{k in f}(H0 h_k + h_k^2/2)
//       d2A_f.
// Units: pN/um. A vertex cell's terms couple its closed star, so the Hessian couples
// vertices up to two edges apart (the BlockHessian pattern).
#include "continuum/block_hessian.hpp"
#include "core/mesh.hpp"
#include "discrete/bending_energy.hpp"

namespace rbc {

/// Adds scale x the Juelicher-Helfrich Hessian at x (3 x N, um) into h.
void add_juelicher_hessian(const Positions& x, const Topology& topo,
                           const BendingParameters& params, BlockHessian& h, double scale = 1.0);

}  // namespace rbc
