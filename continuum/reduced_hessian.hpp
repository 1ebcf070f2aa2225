// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The continuum Lagrangian Hessian on the mirror-symmetric states, P' d2L P (core/
// mirror_symmetry.hpp), assembled from one element per orbit. For an invariant element energy
// the images of an element contribute equally on symmetric states (E_{g e}(P q) = E_e(P q)),
// so P' d2L P = sum over representative elements e of |orbit(e)| P_e' d2L_e P_e: the element
// matrices (the cost of an assembly) are computed for ~1/|G| of the faces, hinges and vertex
// stars, then scattered into the reduced pattern with the signs of P. Equal to reducing the
// full add_lagrangian_hessian (ReducedMatrix) up to rounding (tested).
#include <Eigen/SparseCore>
#include <cstdint>
#include <memory>
#include <vector>

#include "continuum/block_hessian.hpp"
#include "continuum/continuum_model.hpp"
#include "core/mirror_symmetry.hpp"

namespace rbc {

class ReducedLagrangianHessian {
 public:
  /// `group`: the mirrors of the scene (the reduction's group), `reduction` of that group. The
  /// reduced pattern is the representative elements' (no full Hessian is built).
  ReducedLagrangianHessian(const ContinuumModel& model, const MeshSymmetry& group,
                           const SymmetryReduction& reduction);
  /// P' (d2E + area_coef d2A + volume_coef d2V) P at the symmetric state x (3 x N, um),
  /// lower triangle (pN/um). The model must be the one given at construction.
  const Eigen::SparseMatrix<double>& assemble(const Positions& x, double area_coef,
                                              double volume_coef);
  /// Adds a sector target (core/symmetry_stability.hpp): P_c' d2L P_c for the reduction of a
  /// non-trivial character c of the same group (the images of an element contribute equally on
  /// every sector at a symmetric state, chi(g)^2 = 1). Returns its index for sector().
  int add_sector(const SymmetryReduction& sector_reduction);
  int sectors() const { return static_cast<int>(targets_.size()) - 1; }
  /// Element matrices from `model` from now on: another law or bending on the same mesh and
  /// group (the caller's guarantee: NewtonSolver::rebind checks the mesh).
  void rebind(const ContinuumModel& model) { model_ = &model; }
  /// Every sector's matrix at the symmetric state x from one pass over the element matrices.
  void assemble_sectors(const Positions& x, double area_coef, double volume_coef);
  const Eigen::SparseMatrix<double>& sector(int k) { return targets_[k + 1]->matrix; }
  /// Representative faces, hinges and vertex stars (out of F, E, N).
  int representative_faces() const { return static_cast<int>(faces_.size()); }
  int representative_hinges() const { return static_cast<int>(hinges_.size()); }
  int representative_stars() const { return static_cast<int>(stars_.size()); }
  /// A representative element (face, edge or vertex index) and its orbit size.
  struct Element {
    int id, weight;
  };
  const std::vector<Element>& face_representatives() const { return faces_; }
  /// The representative vertices (centres of the stars), one per orbit.
  const std::vector<Element>& star_representatives() const { return stars_; }

 private:
  /// One entry of a representative element's scatter: local matrix entry (a, b) times coef
  /// adds to reduced value `value`.
  struct Scatter {
    int value;
    std::uint8_t a, b;  ///< < 3 x (vertices of the element) <= 255
    std::int16_t coef;  ///< orbit weight x signs of P: +-1, +-2, +-4 or +-8
  };
  /// The scatters of one kind of element, element k's in entries[begin[k], begin[k + 1]) (one
  /// array: no allocation per element).
  struct ScatterList {
    std::vector<Scatter> entries;
    std::vector<int> begin{0};
  };
  /// One reduced matrix (the trivial sector, or another) and the scatter of every
  /// representative element into it.
  struct Target {
    Eigen::SparseMatrix<double> matrix;  ///< reduced pattern (lower triangle) and values
    ScatterList faces, hinges, stars;
  };
  void add_target(const SymmetryReduction& reduction);
  void element_matrices(const Positions& x, double area_coef, double volume_coef);
  void scatter(Target& t);
  const ContinuumModel* model_;
  VertexStars stars_of_;
  std::vector<Element> faces_, hinges_, stars_;
  std::vector<std::unique_ptr<Target>> targets_;  ///< by pointer: no copies as sectors are added
  std::vector<Matrix9d> face_buffer_;
  std::vector<Matrix12d> hinge_buffer_;
  std::vector<std::vector<double>> star_buffer_;
};

}  // namespace rbc
