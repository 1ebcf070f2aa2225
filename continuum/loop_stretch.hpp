// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The optical-tweezers stretch (MODEL.md sections 2 and 4; paper Sec. 5.3.2) of the continuum
// model on the Loop element: the unknowns are the control points of a Loop subdivision surface
// (continuum/loop_surface.hpp), and every term lives on its smooth limit surface:
//   E[x] = sum_q w_q (Jbar Psi(I1, I2) + (kappa/2) (H - H0)^2 J)   in-plane law and bending
//        - F (l . (x - X))                                          bead load
// with the limit surface's area A = sum_q w_q J and enclosed volume V = sum_q w_q x.(x_v x x_w)/3
// held at their rest values by Lagrange multipliers (core/shifted_newton.hpp).
//  - Rest: control points whose limit surface passes through the rest mesh's vertices
//    (loop_interpolating_control_points), so the smooth rest surface interpolates the
//    Evans-Fung surface; it is the stress-free reference of the in-plane law.
//  - Load: a uniform traction of total force F on each bead's cap {X_x >= c} (and {X_x <= -c})
//    of the rest limit surface, integrated by 16 points on each face near the cap plane (the
//    cap's own points only) and 3 elsewhere in the cap; the shares are normalised so that each
//    cap carries exactly F (l is the sum of their basis functions times +-e_x).
//  - Measure: D_A and D_T (core/geometry.hpp measure_diameters) of the limit surface, sampled
//    exactly at the vertices of three levels of subdivision (their limit points).
// The element's bending is validated in docs/validation/loop-element.md; this stretch is a
// library path for measurement (`rbc stretch` runs the linear element).
#include <vector>

#include "continuum/continuum_model.hpp"
#include "continuum/loop_terms.hpp"
#include "continuum/newton_solver.hpp"
#include "core/block_pattern.hpp"
#include "core/shifted_newton.hpp"

namespace rbc {

/// A Loop continuum model ready to evaluate (prepared, immutable state).
struct LoopContinuumModel {
  Topology topo;
  Positions rest;  ///< 3 x N rest control points (um)
  std::vector<LoopQuadraturePoint> quadrature;
  std::vector<LoopMembraneReference> reference;  ///< per quadrature point
  IsotropicMembraneLaw law;
  BendingParameters bending;
  /// 3N: each cap's generalised force per pN of bead force (dimensionless): the x entries of
  /// load_right sum to 1, load_left's likewise, and l = load_right - load_left.
  Eigen::VectorXd load_right, load_left, load;
  double area0_um2 = 0, volume0_um3 = 0;
  int load_points = 0;  ///< quadrature points of the load (both caps)
  /// The limit surface's exact points at the vertices of three levels of subdivision
  /// (loop_limit_sampling_matrix), where D_A and D_T are measured.
  Eigen::SparseMatrix<double> measure_sampling;
};

/// Builds the model on a closed triangulation whose vertices lie on the rest surface
/// (e.g. make_continuum_mesh's projected by evans_fung_project); contact_plane_um: c of the caps
/// (rest_contact_plane), > 0. Throws rbc::InvalidParameter for an empty law, bad parameters or a
/// cap that catches no quadrature point.
LoopContinuumModel build_loop_continuum_model(const TriMesh& rest_on_surface,
                                              const IsotropicMembraneLaw& law,
                                              const BendingParameters& bending,
                                              double contact_plane_um);

/// E(x) at bead force F (pN um), gradient (3 x N, pN; overwritten) when asked; +infinity where
/// an in-plane term is infinite (an element collapsed, the law infinite).
double loop_continuum_energy(const LoopContinuumModel& model, const Positions& x, double force_pN,
                             Positions* grad = nullptr);
/// Limit-surface area (um^2) and volume (um^3) with their gradients (3 x N) when asked.
ConstraintValues loop_constraints(const LoopContinuumModel& model, const Positions& x,
                                  bool gradients);
/// Assembles d2E + area_coef d2A + volume_coef d2V (pN/um) of a Loop model into a fixed block
/// pattern (core/block_pattern.hpp, lower storage: what the Newton solver factorises), each
/// point's blocks added through codes looked up once (prepared state).
class LoopHessianAssembler {
 public:
  explicit LoopHessianAssembler(const LoopContinuumModel& model);
  /// The lower triangle of the 3N x 3N Lagrangian Hessian at x (vertex-major), overwritten.
  const Eigen::SparseMatrix<double>& assemble(const LoopContinuumModel& model, const Positions& x,
                                              double area_coef, double volume_coef);

 private:
  BlockMatrix matrix_;
  std::vector<int> code_offsets_;  ///< point q's codes: codes_[code_offsets_[q] ..), ns x ns
  std::vector<int> codes_;         ///< -1 for the pairs above the diagonal (not stored)
};

/// D_A, D_T (core/geometry.hpp measure_diameters) of the limit surface of control points x (um),
/// measured on its exact points at the vertices of three levels of subdivision: the sampling
/// spacing is an eighth of the mesh's edge, so the extent of a surface with radius of curvature
/// r at its extreme point is missed by at most about (h/8)^2 / (8 r).
Diameters loop_surface_diameters(const LoopContinuumModel& model, const Positions& x);

struct LoopStretchOptions {
  /// The linear element's solver settings (continuum/newton_solver.hpp NewtonOptions' defaults:
  /// 1e-6 pN per control point, steps of at most 1 um, Krylov-corrected chord steps on kept
  /// factorisations, also across forces).
  ShiftedNewtonOptions newton = shifted_newton_options(NewtonOptions{});
  int max_bisections = 6;  ///< halvings of a failing force increment
};

struct LoopStretchPoint {
  double force_pN = 0;
  Diameters diameters;
  NewtonStatus status = NewtonStatus::max_iterations;
  int iterations = 0;      ///< Newton iterations, sub-steps included
  int factorisations = 0;  ///< numeric factorisations, sub-steps included
  double residual_pN = 0;  ///< largest net control-point force at the returned state
  Positions x;             ///< control points (um)
};

/// Equilibria at each force (pN, finite, >= 0), by continuation from the rest state: each from
/// the previous one, a failing increment halved up to max_bisections times. Non-convergence is
/// the point's status, not an exception.
std::vector<LoopStretchPoint> run_loop_stretch(const LoopContinuumModel& model,
                                               const std::vector<double>& forces_pN,
                                               const LoopStretchOptions& options = {});

}  // namespace rbc
