// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The continuum energy, its gradient and the area and volume constraints at a mirror-symmetric
// state (core/mirror_symmetry.hpp), from one element per orbit, for the reduced problem's
// evaluation (core/reduced_problem.hpp). For an element energy invariant under the group,
// E_{g e}(x) = E_e(x) and P' grad E_{g e}(x) = P' grad E_e(x) at a symmetric x, so
//   E = sum over representatives e of |orbit(e)| E_e,
//   P' grad E = P' (sum over representatives e of |orbit(e)| grad E_e),
// and the same for A and V: faces for the in-plane energy and the constraints, vertex cells
// for the Juelicher bending energy (their hinges' L theta and faces' areas are computed for the
// representative cells only). The tweezers work (linear, on the patch vertices) is taken whole.
// The gradient returned is not the full gradient: only its reduction P' g is (it lives on the
// representatives' vertices), and only at symmetric states. The Hessian of the same
// representatives is continuum/reduced_hessian.hpp's.
#include <vector>

#include "continuum/continuum_model.hpp"
#include "continuum/reduced_hessian.hpp"

namespace rbc {

class SymmetricContinuumEnergy {
 public:
  /// The representatives of `orbits` (faces and vertex cells with their orbit sizes), for
  /// `model` (which must outlive this object, as with rebind).
  SymmetricContinuumEnergy(const ContinuumModel& model, const ReducedLagrangianHessian& orbits);
  /// Another law or bending on the same mesh and group (NewtonSolver::rebind).
  void rebind(const ContinuumModel& model) { model_ = &model; }
  /// E(x; F) (pN um) at the symmetric state x (3 x N, um), with grad (3 x N, pN, overwritten)
  /// whose reduction is the reduced gradient, and c's area and volume with gradients of the
  /// same kind. Returns +infinity (grad and c unspecified) where continuum_energy does: a
  /// collapsed element or an infinite in-plane law.
  double evaluate(const Positions& x, double force_pN, Positions& grad, ConstraintValues& c);

 private:
  const ContinuumModel* model_;
  std::vector<ReducedLagrangianHessian::Element> faces_, cells_;
  /// Hinges and faces of the representative cells (each once), with the cells' weight at each
  /// of their vertices (0 for a vertex that is no representative).
  std::vector<int> cell_edges_, cell_faces_;
  std::vector<double> weight_;  ///< per vertex
  // Scratch: per edge L theta and its gradient, per face area and its gradient (entries of the
  // cell edges and faces only), per vertex h = H - H0.
  std::vector<double> lt_, af_, h_;
  std::vector<Eigen::Matrix<double, 3, 4>> glt_;
  std::vector<Eigen::Matrix3d> gaf_;
};

}  // namespace rbc
