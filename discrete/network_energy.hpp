// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The shared-geometry evaluation path of a network model. One pass computes what
// several terms need from x: every face's area vector and area, the totals A and V, every
// hinge's length and dihedral angle. Each term then turns these into its energy and the
// coefficients of four geometric derivatives (dE/dA_f, dE/dV, dE/dL_e, dE/dtheta_e), and one
// assembly pass applies the chain rule. The physics stays in each term's own file; this file
// holds geometry and the chain rule only.
#include <vector>

#include "core/mesh.hpp"

namespace rbc {

/// Geometry of positions x on a mesh, computed once per evaluation (network_geometry). Eigen
/// vectors rather than std::vector: every entry is written, so nothing is zeroed first.
struct NetworkGeometry {
  Eigen::Matrix3Xd face_normal2;    ///< 3 x F: (x1 - x0) x (x2 - x0) = 2 A_f n_f (um^2)
  Eigen::VectorXd face_area;        ///< F: A_f = |face_normal2|/2 (um^2)
  Eigen::VectorXd face_inv_norm2;   ///< F: 1/|face_normal2| = 1/(2 A_f) (1/um^2)
  Eigen::VectorXd edge_length;      ///< E: L_e = |x_b - x_a| (um)
  Eigen::VectorXd edge_inv_length;  ///< E: 1/L_e (1/um)
  /// E: exterior dihedral angle theta_e at edge e (rad; core/geometry.hpp dihedral_angle:
  /// positive at a ridge, 0 when flat), from the two faces' normals.
  Eigen::VectorXd hinge_angle;
  double area_um2 = 0;    ///< sum_f A_f, summed as core/geometry.hpp total_area
  double volume_um3 = 0;  ///< sum_f x0.(x1 x x2)/6, summed as enclosed_volume
};

/// The geometry of x (3 x N, um) on topo. Deterministic for any thread count.
NetworkGeometry network_geometry(const Positions& x, const Topology& topo);

/// The derivatives of an energy with respect to the geometric primitives, which terms fill
/// (accumulate: the evaluation zeroes them) and assemble_geometric_gradient turns into dE/dx.
struct GeometricGradient {
  std::vector<double> face_area;    ///< F: dE/dA_f (pN/um)
  std::vector<double> edge_length;  ///< E: dE/dL_e (pN)
  std::vector<double> hinge_angle;  ///< E: dE/dtheta_e (pN um)
  double area = 0;    ///< dE/dA, a tension the same for every face, added to face_area (pN/um)
  double volume = 0;  ///< dE/dV, the same for every face's tetrahedron (pN/um^2)
  /// Contributions that are none of the above (e.g. the tweezers' bead forces), added into
  /// the gradient directly (3 x N, pN); set by the evaluation, never null inside a term.
  Positions* direct = nullptr;
  /// Zeroed coefficients for topo's faces and edges.
  static GeometricGradient zero(const Topology& topo, Positions* direct);
};

/// grad += sum_f ((c_A,f + c_A) dA_f/dx + c_V dV_f/dx)
///       + sum_e (c_L,e dL_e/dx + c_theta,e dtheta_e/dx)
/// with V_f = x0.(x1 x x2)/6 (pN, 3 x N). Deterministic for any thread count.
void assemble_geometric_gradient(const Positions& x, const Topology& topo,
                                 const NetworkGeometry& geo, const GeometricGradient& c,
                                 Positions& grad);

}  // namespace rbc
