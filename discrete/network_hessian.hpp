// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A projected-Newton Hessian of the network's free energy, the preconditioner of the
// zero-temperature stretch (discrete/stretch.hpp). Prepared state (the block sparsity
// pattern and each element's place in it) is built once per network; assemble() refills
// the values in place.
#include <Eigen/SparseCore>
#include <vector>

#include "core/block_pattern.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/element_hessian.hpp"
#include "discrete/network.hpp"

namespace rbc {

/// Which vertex pairs the bending term may couple.
enum class BendingCoupling {
  /// Every pair in a closed vertex star (vertices up to two edges apart): the exact
  /// Gauss-Newton term of Juelicher's energy; more fill in the Cholesky factor.
  two_ring,
  /// Only mesh edges: a pair (a, b) two edges apart is dropped and replaced by its
  /// diagonal bound w (u_a u_a^T + u_b u_b^T), which keeps the matrix >= the exact
  /// Gauss-Newton term (so still positive semidefinite) with the fill of the links alone.
  one_ring,
};

struct NetworkHessianOptions {
  BendingCoupling bending_coupling = BendingCoupling::two_ring;
  /// Diagonal shift as a fraction of the mean diagonal: makes the rigid-body modes (and the
  /// constraint directions, which the Woodbury correction adds) positive. Dimensionless.
  double shift_fraction = 1e-4;
  /// Juelicher: include the hinge curvature term (kappa/2)(h_a + h_b) d2(L_e theta_e)
  /// (12 x 12 per hinge by automatic differentiation; projected when `project`).
  bool hinge_curvature = false;
  /// Project every element matrix onto the semidefinite cone. false gives the exact
  /// Hessian (with hinge_curvature, Juelicher bending, zero shift), indefinite in general:
  /// for tests, not for Cholesky.
  bool project = true;
  void validate() const;  ///< shift_fraction in [0, 1)
};

/// The global constraints' first-order state at x: the total tension
/// sigma = lambda_A + k_A (A - A0) (pN/um) and pressure p = lambda_V + k_V (V - V0)
/// (pN/um^2) of the augmented Lagrangian; their curvature terms are sigma d2A + p d2V.
struct ConstraintCurvature {
  double tension_pN_per_um = 0.0;
  double pressure_pN_per_um2 = 0.0;
};

/// 3N x 3N symmetric positive semidefinite (+ shift) matrix, pN/um, lower triangle stored
/// in 3 x 3 vertex blocks (diagonal blocks full), for CHOLMOD with Eigen::Lower. Sum of:
///  - per face f (a, b, c), the 9 x 9 element matrix
///      K_f = 1/2 sum_{links e of f} K_e + s''(J)/Abar dA dA^T + (s'(J) + sigma + beta_f) d2A
///            + p d2V,
///    K_e = [H -H; -H H], H = sqrt3 (V' I + 2 V'' d d^T / Lbar^2) the exact link Hessian
///    (link_energy.hpp), beta_f = -(kappa/3) sum_{k in f} (H0 h_k + h_k^2/2) Juelicher's
///    area-curvature coefficient, projected onto the semidefinite cone. Splitting each link
///    between its two faces before projecting keeps the cancellation between link tension
///    and steric pressure (a tension-free membrane at rest has no out-of-plane stiffness
///    from either), which a per-term projection would lose;
///  - Juelicher bending, the rank-one (Gauss-Newton) part of the exact Hessian
///      (kappa/A_v) u_v u_v^T,  u_v = dM_v - (H0 + h_v) dA_v   over each closed star;
///    the hinge curvature term (kappa/2)(h_a + h_b) d2(L theta) is optional (small: |h| L
///    << 1); Kantor-Nelson bending: k_b max(cos(theta - theta0), 0) dtheta dtheta^T;
///  - the diagonal shift.
///  - each custom term's pieces (NetworkTerm::pieces, LocalPieces::hessian), projected one
///    by one when projecting (a custom bending law replaces Juelicher's blocks: the blocks
///    present are those of the model's list, model_terms(net));
/// The penalty's rank-two part k_A dA dA^T + k_V dV dV^T is not included (apply it by
/// Woodbury); tweezers work is linear and contributes nothing. The list must hold the
/// in-plane and area/volume terms (std::invalid_argument otherwise); a custom term without a
/// Hessian hook contributes nothing.
class NetworkHessian {
 public:
  NetworkHessian(const Network& net, const NetworkHessianOptions& options = {});

  /// Refills the matrix at x (3 x N, um; feasible) and returns it.
  const Eigen::SparseMatrix<double>& assemble(const Positions& x,
                                              const ConstraintCurvature& constraints);
  /// As above, with the projection chosen per call (overrides options.project).
  const Eigen::SparseMatrix<double>& assemble(const Positions& x,
                                              const ConstraintCurvature& constraints, bool project);
  /// The exact Hessian whatever the options (unprojected, with the Juelicher hinge curvature
  /// term, without options.shift_fraction) plus diagonal_shift_pN_per_um times the identity,
  /// into the same matrix (e.g. for the stretch's symmetry check, between two refreshes of the
  /// preconditioner that owns it). Needs BendingCoupling::two_ring (std::logic_error
  /// otherwise: the one-ring pattern drops the pairs two edges apart).
  const Eigen::SparseMatrix<double>& assemble_exact(const Positions& x,
                                                    const ConstraintCurvature& constraints,
                                                    double diagonal_shift_pN_per_um = 0.0);
  const Eigen::SparseMatrix<double>& matrix() const { return m_.matrix(); }
  /// Assembles from now on for net, a network of the same mesh (vertex count and faces) and
  /// bending law whose parameters may differ (a kept preconditioner used for the next
  /// parameter set); std::invalid_argument otherwise, or when either model has custom terms.
  /// Reads only net and this object's copy of its mesh: the network it served may be gone.
  void rebind(const Network& net);

 private:
  struct Group {              ///< vertices of a rank-one term (a vertex star or a hinge)
    int first = 0, size = 0;  ///< range in group_vertices_
  };

  /// project: per element; hinges: with the hinge curvature term; shift: the diagonal shift
  /// added (pN/um).
  const Eigen::SparseMatrix<double>& assemble_terms(const Positions& x,
                                                    const ConstraintCurvature& constraints,
                                                    bool project, bool hinges, double shift);
  void prepare_hinges();  ///< hinge_codes_ and hinge_k_ (built when first needed)

  struct CustomTerm {  ///< a custom term's pieces (LocalPieces::hessian)
    const NetworkTerm* term = nullptr;
    PieceLayout layout;
    std::vector<int> codes;  ///< per piece, size^2 codes (k, l) row-major
    std::vector<Eigen::MatrixXd> matrices;
  };

  const Network* net_;
  int vertices_ = 0;  ///< of the mesh the pattern is of (rebind compares with these, not net_)
  Faces faces_;
  NetworkHessianOptions opt_;
  bool juelicher_ = false, dihedral_ = false;  ///< bending kinds in the model's list
  std::vector<CustomTerm> custom_;
  BlockMatrix m_;                ///< lower block storage (core/block_pattern.hpp)
  VertexStars stars_;            ///< Juelicher cells' closed stars
  std::vector<int> face_edges_;  ///< 3 per face: edges (0,1), (1,2), (2,0)
  std::vector<int> face_codes_;  ///< 9 per face, local (k, l) row-major
  std::vector<Group> groups_;
  std::vector<int> group_vertices_;
  std::vector<int> group_codes_;  ///< per group, size^2 codes (k, l) row-major
  std::vector<int> group_code_offsets_;
  std::vector<int> hinge_codes_;  ///< 16 per edge (a, b, c, d), once the hinge term is used
  // Work buffers reused across assemblies.
  std::vector<Matrix9d> face_k_;
  std::vector<double> group_u_;  ///< 3 x group size per group
  std::vector<double> group_w_;
  std::vector<Matrix12d> hinge_k_;
};

}  // namespace rbc
