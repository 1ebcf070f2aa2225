// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The numerical cell problem (MODEL.md section 3; Hartmann 2008 Sec. 3.2-3.3, Theorems 2-3):
// a periodic planar spectrin network carrying the SAME energy units as discrete/ (one
// link = link_energy, one face = steric_face_energy, positions embedded at z = 0), with
// the macroscopic deformation F imposed through the periodic box,
//   x_i = F X_i + u_i,   edge (i -> image of j): d = F D_e + u_j - u_i,
// internal displacements u relaxed by Newton's method (vertex 0 pinned: translations),
//   Psi_hom(F) = min_u E(F, u) / |det box|                                  [pN/um],
// and the relaxed tangent by the Schur complement over the internal degrees of freedom,
//   d2Psi_hom/dF2 = (E_FF - E_Fu E_uu^{-1} E_uF) / |det box|   (envelope theorem).
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <vector>

#include "core/lbfgs.hpp"
#include "core/progress.hpp"
#include "discrete/steric_energy.hpp"
#include "discrete/wlc.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {

/// One link from vertex i to a periodic image of vertex j: reference vector D (um) and
/// rest length Lbar_e = |D|.
struct PeriodicEdge {
  int i = 0, j = 0;
  Eigen::Vector2d ref = Eigen::Vector2d::Zero();
  double lbar_um = 0.0;
};

/// One counter-clockwise face (v0, v1, v2) with reference edge vectors e1 = v1 - v0 and
/// e2 = v2 - v0 between the periodic images used (um) and rest area Abar_f (um^2).
struct PeriodicFace {
  std::array<int, 3> v{};
  Eigen::Vector2d e1 = Eigen::Vector2d::Zero(), e2 = Eigen::Vector2d::Zero();
  double abar_um2 = 0.0;
};

/// A periodic planar network, every element stress-free at its own reference length/area.
struct PeriodicNetwork {
  Eigen::Matrix2d box = Eigen::Matrix2d::Identity();  ///< columns: the two periods (um)
  Eigen::Matrix2Xd points;                            ///< reference positions, 2 x N (um)
  std::vector<PeriodicEdge> edges;
  std::vector<PeriodicFace> faces;
  double reference_area_um2() const { return std::abs(box.determinant()); }
  int vertex_count() const { return static_cast<int>(points.cols()); }
};

/// Largest hexagonal patch (n x n cells) `rbc moduli` accepts: the cell problem there (N =
/// 10,000 vertices, sparse LDL^T per Newton step) takes 9 Newton iterations and 3.4 s CPU;
/// at n = 200 (the former maximum) the factorisation fill of the periodic 40,000-vertex patch
/// made it run for more than 2 min of CPU without finishing (shared/reliability case 31).
inline constexpr int kMaxHexagonalPatchCells = 100;

/// The n x n rhombus of the hexagonal lattice with spacing a (um): vertices i g1 + j g2,
/// g1 = a (1, 0), g2 = a (1/2, sqrt3/2), 3 n^2 links, 2 n^2 faces, box (n g1, n g2).
/// n >= 1 (n = 1 and 2 have links to their own periodic images; still a valid cell).
PeriodicNetwork make_hexagonal_patch(int n, double spacing_um);

/// Number of links at each vertex (size N).
std::vector<int> vertex_degrees(const PeriodicNetwork& net);

/// The in-plane material of the network: V (with expansion), steric parameters and C.
struct NetworkMaterial {
  WlcDensity w;
  StericParameters steric;
  double C_pN_per_um = 0.0;
};
/// Validates p and s; C from the stress-free condition (discrete/steric_energy.hpp).
NetworkMaterial make_network_material(const WlcParameters& p, const StericParameters& s,
                                      WlcExpansion expansion = WlcExpansion::full);

/// F flattened row-major: (F00, F01, F10, F11).
using FlatF = Eigen::Vector4d;

/// E(F, U) in pN um (+infinity if a link reaches Lmax or a face has area <= 0).
/// grad_u (2 x N, pN) and grad_F (dE/dF, pN um) are written when non-null and E is finite.
double patch_energy(const PeriodicNetwork& net, const NetworkMaterial& m, const Eigen::Matrix2d& F,
                    const Eigen::Matrix2Xd& U, Eigen::Matrix2Xd* grad_u = nullptr,
                    Eigen::Matrix2d* grad_F = nullptr);

/// Second derivatives of E at (F, U) over the reduced unknowns (u_1..u_{N-1}, vertex 0
/// pinned; 2(N-1) of them, vertex k at 2(k-1)) and F (FlatF order):
/// uu (sparse, pN/um), uf (pN), ff (pN um). Finite only where E is.
struct PatchHessian {
  Eigen::SparseMatrix<double> uu;
  Eigen::MatrixXd uf;
  Eigen::Matrix4d ff = Eigen::Matrix4d::Zero();
};
PatchHessian patch_hessian(const PeriodicNetwork& net, const NetworkMaterial& m,
                           const Eigen::Matrix2d& F, const Eigen::Matrix2Xd& U);

struct RelaxOptions {
  double force_tolerance_pN = 1e-10;  ///< converged when every net vertex force is below this
  int max_iterations = 200;           ///< Newton iterations before giving up
  /// Stall rule: on a large patch the residual stops decreasing near the tolerance (the
  /// accuracy of the summed forces and of the shifted LDL^T solves; measured at 100 x 100 cells:
  /// 200 iterations and 72 s CPU ending at 1.1e-10 pN against 1e-10). When
  /// `stall_iterations` consecutive Newton steps fail to halve the best residual while it is
  /// within `floor_factor` x force_tolerance_pN, the relaxation ends as converged at the best
  /// iterate seen (CellRelaxResult::at_roundoff_floor set, its residual reported). floor_factor 0
  /// disables the rule.
  int stall_iterations = 4;
  double floor_factor = 1e3;
  /// Factorisations tried per Newton iteration (shift 0, then 1e-8 x the largest |H_ii| growing
  /// tenfold) before the relaxation ends with MinimiserStatus::factorisation_failed; >= 1
  /// (ShiftedNewtonOptions::validate). 30 reaches shifts far above any diagonal entry.
  int max_shift_attempts = 30;
  /// Polled once per Newton iteration; true stops the relaxation by throwing Cancelled.
  CancelCheck cancel;
};

/// Result of the periodic cell problem (relax_patch): the patch's internal vertex positions
/// relaxed at fixed F. Not continuum/relax.hpp's RelaxResult (relax_helfrich, a whole cell).
struct CellRelaxResult {
  MinimiserStatus status = MinimiserStatus::max_iterations;
  int iterations = 0;
  double energy_pNum = 0.0;
  double residual_pN = 0.0;          ///< largest net vertex force at the returned U
  Eigen::Matrix2Xd U;                ///< relaxed displacements (vertex 0 at zero)
  double max_displacement_um = 0.0;  ///< max_i |u_i - u_0|: distance from the affine map
  /// Ended by the stall rule (RelaxOptions::stall_iterations), within floor_factor x the
  /// tolerance but not below it: residual_pN says where.
  bool at_roundoff_floor = false;
  bool converged() const { return status == MinimiserStatus::converged; }
};

/// Newton's method with a shifted sparse LDL^T where the Hessian is indefinite, a
/// feasibility-aware backtracking line search (E = +infinity halves the step). U0 empty
/// means start from the affine map (U = 0). Never returns an infeasible U.
CellRelaxResult relax_patch(const PeriodicNetwork& net, const NetworkMaterial& m,
                            const Eigen::Matrix2d& F, Eigen::Matrix2Xd U0 = {},
                            const RelaxOptions& options = {});

/// Homogenised density, stress and tangents at F.
struct HomogenisedState {
  double psi_pN_per_um = 0.0;       ///< E/|box| at the relaxed U
  Eigen::Matrix2d stress;           ///< dPsi_hom/dF (first Piola, pN/um)
  Eigen::Matrix4d relaxed_tangent;  ///< Schur complement / |box| (pN/um), FlatF order
  Eigen::Matrix4d affine_tangent;   ///< E_FF / |box| at the same U (no relaxation)
  CellRelaxResult relax;
};
/// Relaxes at F (from U0), then forms the tangents. The relaxation status is returned,
/// not thrown; callers report a non-converged state with its residual.
HomogenisedState homogenise_patch(const PeriodicNetwork& net, const NetworkMaterial& m,
                                  const Eigen::Matrix2d& F, Eigen::Matrix2Xd U0 = {},
                                  const RelaxOptions& options = {});

/// Linear moduli from a tangent T (FlatF order) at the rest state:
///   mu = (T[D1, D1] + T[D2, D2]) / 8, D1 = diag(1, -1), D2 = [[0, 1], [1, 0]] (the two pure
///   shears; their mean is the isotropic part), K = T[I, I] / 4 (equibiaxial), i.e.
///   4 mu and 4 K are d2Psi/ds2 along F = I + s D.
LinearModuli moduli_from_tangent(const Eigen::Matrix4d& T);

}  // namespace rbc
