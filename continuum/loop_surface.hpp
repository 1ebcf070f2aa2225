// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The Loop subdivision limit surface of a closed triangle control mesh, evaluated exactly
// (C. Loop, "Smooth subdivision surfaces based on triangles", MS thesis, Utah 1987): the smooth
// surface of the C1 shell elements of Cirak, Ortiz and Schroeder (Int. J. Numer. Meth. Engng 47,
// 2039, 2000).
//
// Subdivision rules (closed meshes): a new vertex on edge (a, b) with opposite vertices c, d is
// 3/8 (x_a + x_b) + 1/8 (x_c + x_d); an old vertex of valence n moves to
// (1 - n beta) x + beta sum(ring), beta(n) = (5/8 - (3/8 + cos(2 pi / n) / 4)^2) / n.
//
// On a triangle whose three corners have valence 6 (a regular patch), the limit surface is the
// quartic box spline of its 12 surrounding control points (Stam, "Evaluation of Loop subdivision
// surfaces", SIGGRAPH 1998; Cirak et al. 2000, appendix). A point of a triangle with a corner of
// another valence is evaluated by subdividing: the point lies in one of the four children, and
// a child away from the irregular corner is regular. LoopSubdivision keeps the levels of global
// subdivision as sparse matrices, so a basis found on a fine regular child is mapped back to
// the control points exactly. Every function value is a linear combination of the control
// points: x(xi) = sum_i N_i(xi) x_i over the triangle's support.
//
// Parameters of a face (a, b, c) (counter-clockwise seen from outside, core/mesh.hpp): xi =
// (v, w) with the point u a + v b + w c of the control triangle, u = 1 - v - w; the tangents
// x_v, x_w then give the outward normal x_v x x_w / |x_v x x_w|.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <vector>

#include "core/mesh.hpp"

namespace rbc {

/// The 12 quartic box-spline basis functions of a regular patch at (v, w) (u = 1 - v - w), with
/// their derivatives: rows N, N_v, N_w, N_vv, N_vw, N_ww; columns the patch's control points in
/// the order of loop_regular_patch. Exact polynomials, any (v, w) (the patch is meant for the
/// triangle v, w >= 0, v + w <= 1).
Eigen::Matrix<double, 6, 12> loop_box_spline(double v, double w);

/// The 12 control points of the regular patch of face f of topo (all three corners of valence
/// 6), in loop_box_spline's order: the face (a, b, c) is (3, 6, 7) (0-based), the one-rings
///   a: b, c, 4, 1, 0, 2;   b: c, a, 2, 5, 9, 10;   c: a, b, 10, 11, 8, 4
/// counter-clockwise seen from outside. `rings` is loop_ordered_rings(topo).
std::array<int, 12> loop_regular_patch(const Topology& topo, const Adjacency& rings, int f);

/// Each vertex's one-ring in counter-clockwise order seen from outside (starting anywhere).
Adjacency loop_ordered_rings(const Topology& topo);

/// One level of Loop subdivision: the fine control mesh (vertices: the old ones moved, then one
/// per edge e at index N + e; faces: face f's children 4 f + k, k = 0, 1, 2 at its corners a, b,
/// c and k = 3 the middle one (m_ab, m_bc, m_ca)). Its limit surface is the coarse mesh's.
TriMesh loop_subdivide(const TriMesh& mesh);

/// beta(n) of Loop's vertex rule (dimensionless); beta(6) = 1/16.
double loop_vertex_weight(int valence);

/// The limit surface's basis at one point: x = sum_k shape(0, k) x_{vertices[k]}, and rows 1-5
/// the derivatives d/dv, d/dw, d2/dv2, d2/dvdw, d2/dw2 in the face's parameters (v, w).
struct LoopBasis {
  std::vector<int> vertices;  ///< control points of the support (indices of the control mesh)
  Eigen::Matrix<double, 6, Eigen::Dynamic> shape;
};

/// The control mesh's subdivision hierarchy (prepared state): each level's topology, ordered
/// rings and its vertices as sparse combinations of the control points. Levels are built as a
/// point needs them (at most max_levels), and only one point evaluation may build at a time
/// (basis() is not const; copies are independent).
class LoopSubdivision {
 public:
  /// topo: a closed oriented manifold (build_topology's checks). max_levels in [0, 8]: a point
  /// of a face with an irregular corner needs about log2(1 / (1 - u_max)) levels, where u_max is
  /// its largest barycentric coordinate towards an irregular corner (2 for the points of
  /// loop_quadrature's 3-point rule). Throws rbc::InvalidParameter otherwise.
  explicit LoopSubdivision(const Topology& topo, int max_levels = 4);

  /// The basis at (v, w) of face f, v, w > 0 and v + w < 1 (strictly inside; a point on an edge
  /// of the face is taken from the face's side). Throws rbc::InvalidParameter for a point
  /// outside the face, or one that needs more than max_levels levels.
  LoopBasis basis(int f, double v, double w);

  const Topology& topology() const { return levels_.front().topo; }
  /// Levels built so far (1: the control mesh only).
  int levels_built() const { return static_cast<int>(levels_.size()); }

 private:
  struct Level {
    Topology topo;
    Adjacency rings;
    std::vector<bool> regular_face;
    /// Rows: this level's vertices; columns: the control points (level 0: empty, identity).
    Eigen::SparseMatrix<double, Eigen::RowMajor> from_control;
  };
  void build_next_level();
  std::vector<Level> levels_;
  int max_levels_;
};

/// Sparse n x n limit-position matrix of the control mesh: the limit point of control vertex i
/// is sum_j L_ij x_j, with (Loop's limit mask) L_ii = 1 - n chi, L_ij = chi for the n ring
/// vertices, chi = 1 / (3 / (8 beta(n)) + n).
Eigen::SparseMatrix<double> loop_limit_matrix(const Topology& topo);

/// Sparse matrix M (rows: the vertices of `levels` levels of subdivision; columns: the control
/// points) whose row i gives the limit point of fine vertex i: the limit surface sampled exactly,
/// limit = (M x')'. levels in [0, 6] (rbc::InvalidParameter otherwise).
Eigen::SparseMatrix<double> loop_limit_sampling_matrix(const Topology& topo, int levels);

/// Control points whose limit surface passes through `points` (3 x N, um) at its vertices:
/// the solution of L X = points (loop_limit_matrix; a sparse LU solve). The interpolating
/// limit surface of vertices placed on a smooth surface.
Positions loop_interpolating_control_points(const Topology& topo, const Positions& points_um);

/// One quadrature point of the limit surface: its basis and its weight in the face's (v, w)
/// domain (the reference triangle's area 1/2 included), so that int_f g dA =
/// sum_q weight_q g(xi_q) |x_v x x_w|(xi_q).
struct LoopQuadraturePoint {
  int face = 0;
  double v = 0, w = 0;
  double weight = 0;
  LoopBasis basis;
};

/// Quadrature on every face of the control mesh with the symmetric 3-point rule of degree 2
/// (points (2/3, 1/6, 1/6) and its permutations, weights 1/6), exact for quadratics in (v, w);
/// points face-major.
std::vector<LoopQuadraturePoint> loop_quadrature(const Topology& topo);

}  // namespace rbc
