// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Mirror symmetry of a mesh and of a scene on it, and the reduction of a problem to its
// symmetric configurations ("the equilibrium is symmetric under x -> -x, y -> -y,
// z -> -z until something buckles").
//
// The stretch scene (Evans-Fung cell, beads pulling along x) is invariant under the
// reflections in the three coordinate planes, the group D2h = {diag(s_x, s_y, s_z), s = +-1}
// of 8 elements. A triangulation keeps a subgroup G of it: the default icosphere (a vertex at
// each dimple, a five-fold axis along z) keeps four, {identity, y -> -y, the inversion
// x -> -x, and their product, the half turn about y}; a rotated one keeps none. An energy
// invariant under G has, on G-symmetric configurations, a G-symmetric gradient, so a critical
// point of the energy restricted to
//   x = P q,   q = the coordinates of one representative vertex per orbit of G (less those
//              the representative's stabiliser pins to a mirror plane),
// is a critical point of the full energy. It need not be a minimum: a symmetric state can be
// a saddle where the cell buckles, so the reduction is an option (never silent) and the tests
// compare it with full solves. P has one entry +-1 per free full coordinate, so the reduced
// gradient is P' grad E (each representative's vertex force times its orbit size) and the
// reduced Hessian P' H P: the same Newton or L-BFGS method on |G| times fewer unknowns.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <string>
#include <vector>

#include "core/mesh.hpp"

namespace rbc {

/// How a solver treats the mirror symmetry of its scene.
enum class Symmetry {
  none,    ///< solve for all 3N coordinates (default)
  mirror,  ///< solve on the configurations symmetric under the reflections the mesh and the
           ///< load share (find_mirror_symmetry; none shared = the full problem)
};
std::string to_string(Symmetry s);
/// "none" or "mirror"; std::invalid_argument otherwise.
Symmetry symmetry_from_string(const std::string& name);

/// Largest distance (um) between a vertex's mirror image and the vertex it is matched with
/// for the reflection to count as a symmetry of the mesh. The default meshes are symmetric to
/// round-off (4e-10 um at 27,042 vertices, the Phi minimisation's rounding); a rotated
/// triangulation misses by 0.05 um or more.
inline constexpr double kMirrorToleranceUm = 1e-8;

/// A subgroup of D2h acting on the vertices of a mesh.
struct MeshSymmetry {
  /// Group elements as sign masks: bit k set = coordinate k changes sign (0 = identity,
  /// 2 = y -> -y, 7 = the inversion). Element 0 is the identity.
  std::vector<int> reflections{0};
  /// image[g][i]: the vertex onto which element g maps vertex i (a permutation).
  std::vector<std::vector<int>> image;
  int order() const { return static_cast<int>(reflections.size()); }
};

/// Sign (+1 or -1) of coordinate k (0, 1, 2) under the reflection with sign mask `mask`.
inline double reflection_sign(int mask, int k) {
  return (mask >> k) & 1 ? -1.0 : 1.0;
}

/// The reflections of D2h that map the mesh onto itself: every vertex x (3 x N, um) onto a
/// vertex within tolerance_um and every face onto a face. Always contains the identity, and is
/// a group: where the reflections that pass are not closed under composition (a mesh off
/// symmetric by about the tolerance), the largest subgroup among them.
MeshSymmetry find_mirror_symmetry(const Positions& x, const Topology& topo,
                                  double tolerance_um = kMirrorToleranceUm);

/// The elements of `symmetry` under which a per-vertex quantity is invariant up to a sign
/// that depends on the element: w[image[g][i]] == sign(mask_g) w[i] for every vertex i
/// (|difference| <= tolerance), e.g. the tweezers' signed force shares with
/// sign = the sign of x (the x -> -x mirror swaps the beads and the force direction). The
/// vertices not listed in `vertices` carry w = 0. The result is a subgroup (an intersection of
/// stabilisers; within the tolerance, the largest subgroup of the elements that pass).
MeshSymmetry keep_invariant(const MeshSymmetry& symmetry, const std::vector<int>& vertices,
                            const std::vector<double>& w, int sign_coordinate, double tolerance);

/// The reduction x = P q of a problem over 3N vertex coordinates (flat layout x0, y0, z0, x1,
/// ...) to the configurations symmetric under a MeshSymmetry.
struct SymmetryReduction {
  int group_order = 1;
  int full_size = 0;     ///< 3N
  int reduced_size = 0;  ///< entries of q
  /// Per full coordinate: its entry of q, or -1 when the symmetry pins it to 0.
  std::vector<int> reduced_index;
  /// Per full coordinate: x_i = sign_i q_{reduced_index_i} (+-1).
  std::vector<double> sign;
  /// Per orbit: the representative vertex, the orbit's size, and its first entry of q
  /// (entries block_offset[o] .. block_offset[o + 1] belong to orbit o).
  std::vector<int> representative, orbit_size, block_offset;
  /// Per entry of q: its orbit.
  std::vector<int> orbit_of_entry;
  bool trivial() const { return group_order == 1; }
};

/// Value (+1 or -1) of the character c (a sign mask, 0 = trivial) at the group element with
/// sign mask `element`: -1 when c and the element share an odd number of flipped coordinates.
inline double character_value(int c, int element) {
  return __builtin_parity(static_cast<unsigned>(c & element)) ? -1.0 : 1.0;
}

/// The characters (one mask each) of the group's one-dimensional representations other than
/// the trivial one: |G| - 1 of them, each the sign pattern of one sector of the full space
/// (the vectors v with v_{g(i)} = chi(g) S_g v_i). A symmetric critical point is a minimum of
/// the full problem only if the Hessian is positive semidefinite on every sector; the
/// constraints of an invariant problem (area, volume) have symmetric gradients, which vanish
/// on the non-trivial sectors.
std::vector<int> nontrivial_characters(const MeshSymmetry& symmetry);

/// P for a symmetry (group order 1: P = I), or, with a character c, the basis P_c of the
/// sector of vectors v with v_{g(i)} = chi_c(g) S_g v_i (nontrivial_characters).
SymmetryReduction make_symmetry_reduction(const MeshSymmetry& symmetry, int character = 0);

/// x = P q (3N entries; pinned coordinates 0).
Eigen::VectorXd expand(const SymmetryReduction& r, const Eigen::VectorXd& q);
/// q = (P'P)^-1 P' x: the symmetric part of x, in reduced coordinates (exact for symmetric x).
Eigen::VectorXd symmetric_part(const SymmetryReduction& r, const Eigen::VectorXd& x);
/// P' v: the reduced gradient of a full gradient v (3N -> reduced_size).
Eigen::VectorXd reduce(const SymmetryReduction& r, const Eigen::VectorXd& v);
/// P' V for each column of V (3N x k -> reduced_size x k).
Eigen::MatrixXd reduce(const SymmetryReduction& r, const Eigen::MatrixXd& v);
/// Largest vertex norm of the full (symmetric) vector whose reduction is gq = P' g: each
/// representative's entries divided by its orbit size (the reduced residual's per-vertex force).
double largest_vertex_norm_of_reduced(const SymmetryReduction& r, const Eigen::VectorXd& gq);
/// Largest vertex norm of P dq (a reduced step's largest vertex displacement).
double largest_vertex_norm_of_expanded(const SymmetryReduction& r, const Eigen::VectorXd& dq);

/// P' H P for symmetric sparse matrices H of one fixed pattern (the lower triangle of H is
/// read; the result stores its lower triangle, compressed). The pattern map is built once;
/// each reduce() is one pass over H's values.
class ReducedMatrix {
 public:
  ReducedMatrix(const SymmetryReduction& reduction, const Eigen::SparseMatrix<double>& pattern);
  /// P' h P (h with the pattern given at construction).
  const Eigen::SparseMatrix<double>& reduce(const Eigen::SparseMatrix<double>& h);
  /// True when h has the pattern this map was built for (size and nonzero count).
  bool matches(const Eigen::SparseMatrix<double>& h) const {
    return h.rows() == rows_ && h.nonZeros() == nonzeros_;
  }

 private:
  Eigen::Index rows_ = 0, nonzeros_ = 0;
  /// Per value of h: the value of the result it adds to (-1: none) and the coefficient.
  std::vector<int> target_;
  std::vector<double> coef_;
  Eigen::SparseMatrix<double> out_;
};

}  // namespace rbc
