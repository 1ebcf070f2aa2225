// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Whether a symmetric critical point found on the mirror-symmetric states (core/
// reduced_problem.hpp) is a minimum of the full problem: "check, don't assume". At a
// symmetric state the full Hessian of an invariant problem is block diagonal over the sectors of
// the group's characters (core/mirror_symmetry.hpp nontrivial_characters); the symmetric solve
// sees the trivial sector only. The invariant constraints' gradients vanish on the other
// sectors, so there the Hessian of the Lagrangian itself must be positive (semi)definite: each
// sector's P_c' H P_c is factorised (sparse Cholesky, |G| - 1 factorisations of ~3N/|G|
// unknowns). A failed factorisation means a direction of negative curvature that breaks the
// symmetry: the cell buckles there, and the symmetric state is a saddle.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <functional>
#include <memory>
#include <vector>

#include "core/mirror_symmetry.hpp"
#include "core/sparse_cholesky.hpp"

namespace rbc {

/// Relative shift of the symmetry check's sector factorisations (SymmetryStabilityCheck::
/// check): the rigid modes of the non-trivial sectors (translations along x, y, z, the turns
/// about x and z), which cost no energy, stay definite, as with the Newton method's smallest
/// shift.
inline constexpr double kSectorShift = 1e-8;
/// Largest coordinate displacement (um) of the first push off an unstable symmetric state.
inline constexpr double kSymmetryPushUm = 1e-3;
/// Pushes tried (1e-3, 1e-2, 1e-1 um), each kSymmetryPushGrowth times the one before, while the
/// full solve ends unconverged or back on the saddle.
inline constexpr int kSymmetryPushAttempts = 3;
inline constexpr double kSymmetryPushGrowth = 10.0;
/// A state farther than this (um, any coordinate) from its symmetric part is not symmetric
/// (the default rest meshes are symmetric to 4e-10 um).
inline constexpr double kSymmetricStartUm = 1e-6;

struct SectorStability {
  bool stable = true;
  int unstable_character = 0;  ///< the first sector found indefinite (0: none)
  int factorisations = 0;
};

/// The most negative curvature (pN/um per um^2 of displacement, returned as a magnitude >= 0)
/// an equilibrium's residual r (its full gradient, 3 x N pN) fakes along a rigid turn of x about
/// a coordinate axis through its centroid. The energy without the bead work is invariant under
/// rotations, so along a turn d = w x (x - c) its Hessian is -g.(w x (w x (x - c)))/|d|^2
/// exactly, where its gradient g = r - (bead forces): the bead part is the physical stiffness
/// of the turn, the residual part is an artefact of the force tolerance. A turn about x (and
/// about z at 0 pN) costs nothing, so the artefact alone decides its sign: measured at 0 pN,
/// N = 1,002, tolerance 1e-3 pN, -3.5e-5 pN/um, while the sectors' smallest curvatures of a
/// shape change are 0.02 to 0.07 pN/um and a buckling soft cell's -0.5 to -1.2.
/// x: the state (3 x N, um), r: the residual of its Lagrangian (3 x N, pN). Callers add twice
/// it to the sector matrices' diagonals (check's absolute_shift), so that the force
/// tolerance's slack along the free turns does not count as buckling.
double rigid_turn_residual_curvature(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& r);

class SymmetryStabilityCheck {
 public:
  /// Sectors of every non-trivial character of `symmetry` (none for the trivial group).
  SymmetryStabilityCheck(const MeshSymmetry& symmetry, const SparseCholeskyOptions& options);
  ~SymmetryStabilityCheck();
  SymmetryStabilityCheck(const SymmetryStabilityCheck&) = delete;
  SymmetryStabilityCheck& operator=(const SymmetryStabilityCheck&) = delete;

  /// h: the full Hessian of the Lagrangian (3N x 3N, lower triangle read, compressed) at a
  /// symmetric state. Stable when every sector's P_c' h P_c + shift I factorises, shift =
  /// relative_shift x the sector's mean |diagonal| (the rigid modes, which cost no energy,
  /// lie in these sectors: the shift keeps them from counting as unstable).
  SectorStability check(const Eigen::SparseMatrix<double>& h, double relative_shift,
                        double absolute_shift = 0.0);
  /// The same from the sector matrices P_c' h P_c themselves (lower triangle), sector k's
  /// given by sector_matrix(k) for k = 0 .. sectors() - 1 (e.g. assembled from one element
  /// per orbit: continuum/reduced_hessian.hpp).
  SectorStability check_sectors(
      const std::function<const Eigen::SparseMatrix<double>&(int k)>& sector_matrix,
      double relative_shift, double absolute_shift = 0.0);
  /// Sector k's character and reduction P_c.
  int character(int k) const;
  const SymmetryReduction& sector_reduction(int k) const;
  /// A deterministic unit vector (3N) of the sector of `character` (pseudo-random from seed):
  /// the push off an unstable symmetric state.
  Eigen::VectorXd sector_direction(int character, unsigned seed) const;
  int sectors() const { return static_cast<int>(sectors_.size()); }

 private:
  struct Sector;
  std::vector<std::unique_ptr<Sector>> sectors_;
  /// Factorises sector s's matrix r plus the relative shift; false if not definite.
  bool factorise(Sector& s, const Eigen::SparseMatrix<double>& r, double relative_shift,
                 double absolute_shift);
  SparseCholeskyOptions options_;
};

}  // namespace rbc
