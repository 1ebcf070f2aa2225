// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A posteriori error indicator of the continuum solution: Zienkiewicz-Zhu stress recovery
// (Zienkiewicz and Zhu, Int. J. Numer. Methods Eng. 24 (1987) 337) on a curved membrane.
//
// The linear triangle's Cauchy surface stress tau_T is constant per element (pN/um; paper
// Sec. 4.1, tau = 2 Psi_2 / J F F^T + Psi_1 P, with F F^T = sum_ab (G^-1)_ab e_a e_b^T in the
// current edges e_a and P = I - n n^T the element's tangent projector). The recovered nodal
// stress is the area-weighted average of the adjacent elements' stresses, each first turned
// into the vertex's tangent plane by the smallest rotation taking the element normal to the
// vertex normal (area-weighted face normals): R tau_T R^T. Over element T the recovered field
// tau* is the linear interpolation of its vertices' recovered stresses, turned back into T's
// plane; the indicator is its L2 distance from the element stress,
//   eta_T = ( integral_T |tau* - tau_T|_F^2 dA )^(1/2)   (pN),
// exact for the linear integrand: integral_T |sum_i N_i d_i|^2 = A_T / 12 (sum_i |d_i|^2 +
// |sum_i d_i|^2). The rotations make it vanish on every homogeneous deformation the element
// represents exactly, flat or curved (a uniformly stretched flat patch, a uniformly inflated
// sphere: there R (t P_T) R^T = t P_v); on a smooth non-uniform field it falls as O(h).
#include <Eigen/Core>
#include <vector>

#include "continuum/continuum_model.hpp"
#include "continuum/membrane_element.hpp"
#include "homogenise/membrane_law.hpp"

namespace rbc {

/// The element's Cauchy surface stress tensor tau (3 x 3, symmetric, tangent to the current
/// triangle; pN/um). Its nonzero eigenvalues are principal_tensions' t1, t2. Infinite entries
/// where the law is infinite or the element collapsed (J < kCollapsedElementRatio).
Eigen::Matrix3d element_stress_tensor(const IsotropicMembraneLaw& law, const MembraneReference& ref,
                                      const Vec3& x0, const Vec3& x1, const Vec3& x2);

/// Zienkiewicz-Zhu indicator eta_T (pN) of each face, from the per-face stress tensors
/// (pN/um) on the triangles `faces` (3 x F, any triangle soup with shared vertices; open
/// meshes too) at positions x (3 x N, um). std::invalid_argument if the sizes disagree.
Eigen::VectorXd recovery_error_indicator(const Positions& x, const Faces& faces,
                                         const std::vector<Eigen::Matrix3d>& stress_pN_per_um);

/// The indicator of the continuum model's in-plane stress at x (per element, pN); zero
/// without an in-plane law.
Eigen::VectorXd error_indicator(const ContinuumModel& model, const Positions& x);

}  // namespace rbc
