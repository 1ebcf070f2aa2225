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
//  - Symmetry: on a mesh with mirrors (the default icosphere keeps four of the scene's eight),
//    the solve can run on the symmetric states from one quadrature point per orbit, with the
//    linear element's stability check (LoopStretchOptions::symmetry).
// The element is validated in docs/validation/loop-element.md; `rbc stretch --element loop` and
// the trade-off table's Loop rows (compare/methods.hpp Method::loop) run this stretch.
#include <vector>

#include "continuum/continuum_model.hpp"
#include "continuum/loop_terms.hpp"
#include "continuum/newton_solver.hpp"
#include "core/block_pattern.hpp"
#include "core/mirror_symmetry.hpp"
#include "core/progress.hpp"
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
  double area0_um2 = 0, volume0_um3 = 0;       ///< of the rest limit surface
  double cap_right_um2 = 0, cap_left_um2 = 0;  ///< the caps' areas on the rest limit surface
  int load_points = 0;                         ///< quadrature points of the load (both caps)
  /// The limit surface's exact points at the vertices of three levels of subdivision
  /// (loop_limit_sampling_matrix), where D_A and D_T are measured, and at the control mesh's
  /// own vertices (no subdivision). Their weights are >= 0 and sum to 1 in each row.
  Eigen::SparseMatrix<double, Eigen::RowMajor> measure_sampling, vertex_sampling;
};

/// Builds the model on a closed triangulation whose vertices lie on the rest surface
/// (e.g. make_continuum_mesh's projected by evans_fung_project); contact_plane_um: c of the caps
/// (rest_contact_plane), > 0. Throws rbc::InvalidParameter for an empty law, bad parameters or a
/// cap that catches no quadrature point.
LoopContinuumModel build_loop_continuum_model(const TriMesh& rest_on_surface,
                                              const IsotropicMembraneLaw& law,
                                              const BendingParameters& bending,
                                              double contact_plane_um);

/// The quadrature points an evaluation visits, each standing for `multiplicity` points: every
/// point once (the full problem), or one point per orbit of a mirror group weighted by the
/// orbit's size (loop_orbit_points). On a state symmetric under the group both sets give the
/// same energy and constraints, and the same reduced gradients and Hessian P' g, P' H P
/// (core/mirror_symmetry.hpp): the density of an image point at the mirrored state is the
/// point's own, and P' maps a mirrored gradient to the same vector.
struct LoopPointSet {
  std::vector<int> points;           ///< indices into LoopContinuumModel::quadrature
  std::vector<double> multiplicity;  ///< per entry of points
};
/// Every quadrature point of the model, multiplicity 1.
LoopPointSet loop_all_points(const LoopContinuumModel& model);
/// One quadrature point per orbit of `symmetry` (reflections mapping the control mesh onto
/// itself, find_mirror_symmetry on model.rest), the smallest index of each, with the orbit's
/// size. Throws std::invalid_argument when the symmetry is not one of this mesh's (a face's
/// image is not a face) or the quadrature is not loop_quadrature's.
LoopPointSet loop_orbit_points(const LoopContinuumModel& model, const MeshSymmetry& symmetry);

/// One pass over the points: E(x) at bead force F (pN um, returned; +infinity where an in-plane
/// term is infinite: an element collapsed, the law infinite) with its gradient (3 x N, pN;
/// overwritten) when grad is given, and the area (um^2) and volume (um^3) with their gradients
/// (3 x N) when constraints is given (gradients only with grad; they are complete even where
/// the energy is infinite, the energy's gradient then is not). The bead load's term is the full
/// model's whatever the set.
double loop_evaluate(const LoopContinuumModel& model, const LoopPointSet& set, const Positions& x,
                     double force_pN, Positions* grad, ConstraintValues* constraints);

/// E(x) at bead force F (pN um), gradient (3 x N, pN; overwritten) when asked; +infinity where
/// an in-plane term is infinite (an element collapsed, the law infinite).
double loop_continuum_energy(const LoopContinuumModel& model, const Positions& x, double force_pN,
                             Positions* grad = nullptr);
/// Limit-surface area (um^2) and volume (um^3) with their gradients (3 x N) when asked.
ConstraintValues loop_constraints(const LoopContinuumModel& model, const Positions& x,
                                  bool gradients);
/// Assembles d2E + area_coef d2A + volume_coef d2V (pN/um) of a Loop model over a point set
/// (every point by default) into a fixed block pattern (core/block_pattern.hpp, lower storage:
/// what the Newton solver factorises), each point's blocks added through codes looked up once
/// (prepared state).
class LoopHessianAssembler {
 public:
  explicit LoopHessianAssembler(const LoopContinuumModel& model);
  LoopHessianAssembler(const LoopContinuumModel& model, LoopPointSet set);
  /// The lower triangle of the 3N x 3N Lagrangian Hessian at x (vertex-major), overwritten.
  const Eigen::SparseMatrix<double>& assemble(const LoopContinuumModel& model, const Positions& x,
                                              double area_coef, double volume_coef);

 private:
  LoopPointSet set_;
  BlockMatrix matrix_;
  std::vector<int> code_offsets_;  ///< entry e's codes: codes_[code_offsets_[e] ..), ns x ns
  std::vector<int> codes_;         ///< -1 for the pairs above the diagonal (not stored)
};

/// D_A, D_T (core/geometry.hpp measure_diameters) of the limit surface of control points x (um),
/// measured on its exact points at the vertices of three levels of subdivision: the sampling
/// spacing is an eighth of the mesh's edge, so the extent of a surface with radius of curvature
/// r at its extreme point is missed by at most about (h/8)^2 / (8 r).
/// Only the sample points that can be extreme are formed: each is a convex combination of its
/// support's control points (the masks are positive), so a point whose control points all lie
/// short of the extremes of the limit points at the mesh's vertices in x, and strictly inside
/// their octagon of extremes in (y, z), is neither an extreme in x nor a vertex of the hull in
/// (y, z). The result is measure_diameters of all the sample points (to rounding: the limit
/// points at the mesh's vertices are formed by their own mask).
Diameters loop_surface_diameters(const LoopContinuumModel& model, const Positions& x);

struct LoopStretchOptions {
  /// The linear element's solver settings (continuum/newton_solver.hpp NewtonOptions' defaults:
  /// 1e-6 pN per control point, steps of at most 1 um, Krylov-corrected chord steps on kept
  /// factorisations, also across forces).
  ShiftedNewtonOptions newton = shifted_newton_options(NewtonOptions{});
  int max_bisections = 6;  ///< halvings of a failing force increment
  /// Symmetry::mirror: solve on the states symmetric under the mirrors the mesh and the load
  /// share (core/mirror_symmetry.hpp; none shared: the full problem), from one quadrature point
  /// per orbit (loop_orbit_points). Each converged symmetric state is checked in every other
  /// sector of the group (core/symmetry_stability.hpp); a saddle is pushed off along its
  /// unstable sector and solved in full, as are all later forces.
  Symmetry symmetry = Symmetry::none;
};

struct LoopStretchPoint {
  double force_pN = 0;
  Diameters diameters;
  NewtonStatus status = NewtonStatus::max_iterations;
  double wall_s = 0;       ///< wall time of this force's solve and check (s)
  int iterations = 0;      ///< Newton iterations, sub-steps included
  int factorisations = 0;  ///< numeric factorisations, sub-steps included
  double residual_pN = 0;  ///< largest net control-point force at the returned state
  double energy_pNum = 0;  ///< E at the returned state (pN um)
  double area_drift = 0, volume_drift = 0;  ///< (A - A0) / A0, (V - V0) / V0 there
  ConstraintMultipliers multipliers;        ///< lambda_A (pN/um), lambda_V (pN/um^2) there
  int symmetry_order = 1;  ///< order of the mirror group the solve was reduced by (1: full)
  int stability_factorisations = 0;  ///< sector factorisations of the symmetry check
  bool symmetry_broken = false;      ///< the symmetric state was a saddle: solved in full
  Positions x;                       ///< control points (um)
};

/// Equilibria at each force (pN, finite, >= 0), by continuation from the rest state: each from
/// the previous one, a failing increment halved up to max_bisections times. Non-convergence is
/// the point's status, not an exception. progress: one line per force ("F = ... pN: D_A = ...").
std::vector<LoopStretchPoint> run_loop_stretch(const LoopContinuumModel& model,
                                               const std::vector<double>& forces_pN,
                                               const LoopStretchOptions& options = {},
                                               const ProgressSink& progress = {});

}  // namespace rbc
