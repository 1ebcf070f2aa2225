// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Zero-temperature optical-tweezers stretch of the discrete network: for each force, the
// free energy is minimised (L-BFGS) from the previous equilibrium (continuation in force),
// with area and volume held by augmented-Lagrangian outer updates. Optionally on the
// mirror-symmetric states only (StretchOptions::symmetry, core/mirror_symmetry.hpp).
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "core/lbfgs.hpp"
#include "core/mirror_symmetry.hpp"
#include "core/progress.hpp"
#include "core/validation.hpp"
#include "discrete/augmented_lagrangian.hpp"
#include "discrete/network.hpp"
#include "discrete/newton_preconditioner.hpp"
#include "discrete/stretch_state.hpp"

namespace rbc {

struct StretchPoint;

/// Outcome of one force of the discrete stretch. to_string gives the words printed and written
/// to JSON ("converged", "iteration limit reached", ...).
enum class StretchStatus {
  converged,
  max_iterations,        ///< the iteration or evaluation budget of the force was spent
  line_search_failed,    ///< L-BFGS found no acceptable step
  infeasible_start,      ///< the start is outside the energy's domain
  time_budget,           ///< StretchOptions::time_budget_s passed
  constraints_not_held,  ///< converged, but area/volume not held after the updates
  factorisation_failed,  ///< the minimiser found no definite factorisation (not L-BFGS)
};
std::string to_string(StretchStatus s);
std::ostream& operator<<(std::ostream& os, StretchStatus s);
/// The stretch status of an L-BFGS outcome.
StretchStatus stretch_status(MinimiserStatus s);

/// Networks of at least this many vertices are preconditioned at every force (see
/// StretchOptions::precondition_min_vertices).
inline constexpr int kLargeNetworkVertices = 1500;

struct StretchOptions {
  LbfgsOptions minimiser;         ///< force_tolerance in pN per vertex
  int max_outer_iterations = 40;  ///< augmented-Lagrangian multiplier updates per force
  /// Penalty schedule of the augmented-Lagrangian driver (discrete/augmented_lagrangian.hpp).
  AugmentedLagrangianSchedule augmented_lagrangian;
  /// Precondition L-BFGS with a sparse Cholesky factorisation (CHOLMOD) of the projected
  /// Newton Hessian (discrete/newton_preconditioner.hpp: network_hessian.hpp + the
  /// area/volume penalties by Woodbury) for networks with at least this many vertices:
  /// those with kLargeNetworkVertices or more at every force, smaller ones at forces up to
  /// small_network_max_force_pN. 0 = always (the default), INT_MAX = never (plain L-BFGS).
  /// Measured (one thread, the 13 Mills forces plus 250, 300, 400 and 500 pN): every network
  /// from N = 100 to 1,200 converges at every force with the preconditioner, in 2.0-2.5x
  /// less wall time than plain L-BFGS (N = 250: 0.73 vs 1.67 s; 1,000: 3.5 vs 5.7 s); the
  /// diameters differ by up to 1.5e-4 relative at the default 1e-3 pN tolerance and by 4e-6
  /// at 1e-5 pN, i.e. by the tolerance's slack, not the answer.
  int precondition_min_vertices = 0;
  /// Largest force (pN) at which a network smaller than kLargeNetworkVertices is
  /// preconditioned; above it plain L-BFGS. At N = 300 and 2,000 pN (above the documented
  /// kMaxDiscreteForce_pN) the preconditioned solve stalls for minutes where plain L-BFGS
  /// converges; the measured range ends at 500 pN.
  double small_network_max_force_pN = 500.0;
  NewtonPreconditionerOptions preconditioner;
  /// Refactorise at the current point when this many L-BFGS iterations since the last
  /// factorisation have not reduced the largest vertex force tenfold (0 = factorise once
  /// per force, at its start).
  int refresh_interval = 10;
  /// Whether a force starts with a fresh factorisation when the shared preconditioner
  /// (run_stretch) already holds one from the previous force: true = always refactorise at
  /// the start of each force (the default); false = keep the previous factorisation and
  /// refactorise only when L-BFGS stalls (refresh_interval). The tweezers work is linear,
  /// so the Hessian does not depend on the force itself, only on the shape and multipliers.
  bool refactorise_at_force_start = true;
  /// Largest vertex displacement per line-search trial, in units of the shortest rest link,
  /// when minimiser.max_step <= 0: plain L-BFGS steps are capped at 0.25 (its first steps
  /// are poorly scaled); Newton-like preconditioned steps at 4 (measured at N = 27,000,
  /// 88 pN: 32 iterations instead of 76 with a cap of 1).
  double plain_max_step_links = 0.25, preconditioned_max_step_links = 4.0;
  /// Wall-clock budget of one force (s), all multiplier updates included; 0 = none. The
  /// iteration budget of one force is minimiser.max_iterations, summed over the updates.
  double time_budget_s = 0.0;
  /// Energy evaluations one force may use, as a multiple of minimiser.max_iterations (line
  /// searches that keep hitting the infeasible domain cost many evaluations per iteration:
  /// measured at 1e6 pN, N = 300, 600 s without this budget).
  int evaluations_per_iteration_budget = 4;
  /// Symmetry::mirror: minimise on the configurations symmetric under the mirrors the rest
  /// mesh and the bead load share (discrete/tweezers.hpp tweezers_scene_symmetry; 4 on most
  /// default meshes, 2 where the contact patch's edge splits a mirror pair, e.g. N = 500 and
  /// 8,000; see core/mirror_symmetry.hpp), with |G| times fewer unknowns: L-BFGS on q
  /// (x = P q), the Newton preconditioner on P'HP. The force tolerance and the step cap still
  /// measure full per-vertex forces and displacements, and the reported residual is the full
  /// problem's, evaluated at the end. A symmetric equilibrium may be a saddle where the cell
  /// would buckle: an option, not the default. A group of order 1 is the full problem (the
  /// same computation as Symmetry::none).
  Symmetry symmetry = Symmetry::none;
  /// With Symmetry::mirror: after each converged symmetric force, check that the state is a
  /// minimum of the full problem (core/symmetry_stability.hpp: the exact network Hessian and
  /// |G| - 1 sector factorisations); where it is not, the state is pushed 1e-3 um along the
  /// unstable sector and that force is solved in full (StretchPoint::symmetry_broken). A
  /// start that is itself not symmetric to 1e-6 um (a buckled state of the previous force, or
  /// a warm start from a run without the option, symmetric only to its tolerance) is solved
  /// in full. The rigid turns about x (and about z at 0 pN) cost nothing, and the force
  /// tolerance's residual gives them a slightly negative curvature: the check allows twice
  /// that (computed from the residual), so a turn is not taken for buckling. With the
  /// dihedral bending model the checked Hessian holds only its Gauss-Newton bending term.
  /// Cost at N = 27,042: one exact Hessian and three sector factorisations of ~20,000
  /// unknowns, 0.7 to 1.3 s per force (loaded 2-core machine). Off: trust the symmetry (a
  /// saddle is then reported as an equilibrium).
  bool symmetry_check = true;
  /// Whether forces above kMaxDiscreteForce_pN are accepted (still finite and >= 0): only for
  /// studies of where the solver stops working (`rbc stability`'s solver-budget ladder). Off:
  /// validate(forces) refuses them, so every front end keeps to the documented range.
  bool beyond_documented_force_range = false;
  StretchOptions() {
    minimiser.force_tolerance = 1e-3;
    minimiser.max_iterations = 50000;
  }
  /// Throws rbc::InvalidParameter naming the value: minimiser.validate(), the force tolerance
  /// (largest net vertex force, pN) in (0, kMaxForceTolerance_pN], max_outer_iterations in
  /// [1, 10000], precondition_min_vertices and refresh_interval >= 0, step caps finite > 0.
  /// Called by run_stretch after each force is solved, before the next starts (e.g. to write
  /// that force's shape as soon as it exists). Empty = nothing.
  std::function<void(const StretchPoint&)> on_point;
  void validate() const;
  /// validate() and every force: finite and in [0, kMaxDiscreteForce_pN] pN
  /// (validate_discrete_force), or finite and >= 0 with beyond_documented_force_range. Called
  /// by run_stretch, StretchSweepSolver::run and solve_equilibrium before any work, so every
  /// front end (CLI, calibration, Python) is held to the same limits.
  void validate(const std::vector<double>& forces_pN) const;
};

/// Largest force tolerance accepted (pN): beyond 10 pN an "equilibrium" may be no closer to
/// the answer than the rest shape is at the smallest Mills force (16 pN).
inline constexpr double kMaxForceTolerance_pN = 10.0;

/// Largest total bead force (pN) the discrete stretch is documented to handle, checked up front
/// by StretchOptions::validate(forces) (validate_discrete_force). Measured (rbc stretch --force F,
/// one force from the rest shape, Release, 1 thread, loaded machine): 500 pN converges at N = 300
/// in 433 L-BFGS iterations (1.5 s) and at N = 2,000 (preconditioned) in 47 (6.7 s); 1,000 pN
/// converges at N = 300 (3.2 s) but did not finish at N = 2,000 in 400 s, and 1e6 pN not at N = 300
/// in 600 s. At 500 pN the cell is stretched to D_A ~ 21 um, 2.7x its diameter, as links approach
/// Lmax (Lmax/Lbar = 3.17): 2.6x the Mills range (0-193 pN), past Fig. 7's 300 pN.
inline constexpr double kMaxDiscreteForce_pN = 500.0;

/// Throws rbc::InvalidParameter ("force (discrete model) must be finite and in [0, 500] pN, got
/// ...") unless the force is finite and in [0, kMaxDiscreteForce_pN].
inline void validate_discrete_force(double force_pN) {
  require_finite_in_range("force (discrete model)", "pN", force_pN, 0.0, kMaxDiscreteForce_pN,
                          Ends::closed_closed);
}

/// One equilibrium of the stretch.
struct StretchPoint {
  double force_pN = 0;
  double axial_um = 0, transverse_um = 0;
  double energy_pNum = 0;  ///< free energy without the constraint terms
  int iterations = 0;      ///< L-BFGS iterations summed over outer updates
  int factorisations = 0;  ///< preconditioner factorisations (0: plain L-BFGS)
  bool converged = false;
  double residual_pN = 0;                   ///< largest net vertex force at the end
  double area_drift = 0, volume_drift = 0;  ///< relative (A - A0)/A0, (V - V0)/V0
  double wall_s = 0;
  int vertices = 0;
  StretchStatus status = StretchStatus::max_iterations;  ///< to_string(status): in words
  Positions x;                                           ///< equilibrium positions (um)
  /// Area/volume multipliers (lambda_A pN/um, lambda_V pN/um^2) and penalty stiffness scale of
  /// the last minimisation: x is a stationary point of network_energy at
  /// LoadState{force_pN, multipliers, stiffness_scale}.
  ConstraintMultipliers multipliers;
  double stiffness_scale = 1.0;
  bool warm = false;  ///< solved from a given StretchState entry
  /// StretchOptions::symmetry = mirror: the order of the mirror group the force's final solve
  /// was reduced by (1 = solved in full) and whether the equilibrium is not mirror-symmetric
  /// (its symmetric state was a saddle, or it started from a buckled state; both solved in
  /// full).
  int symmetry_order = 1;
  bool symmetry_broken = false;
};

/// Whether a force is solved with the Newton preconditioner (StretchOptions).
inline bool preconditioned(const StretchOptions& o, int vertices, double force_pN) {
  return vertices >= o.precondition_min_vertices &&
         (vertices >= kLargeNetworkVertices || force_pN <= o.small_network_max_force_pN);
}

/// Solves one force from x (updated in place) carrying the multipliers along.
StretchPoint solve_equilibrium(const Network& net, double force_pN, Positions& x,
                               ConstraintMultipliers& lambda, const StretchOptions& options,
                               const ProgressSink& progress = {});

/// As above, with a prepared preconditioner for this network (reused across calls: its
/// symbolic analysis is done once). nullptr: one is built here when N >= the threshold. It is
/// the full problem's: with Symmetry::mirror the reduced problem's (and the symmetry check's)
/// prepared state is built per call (run_stretch keeps them for the whole run).
StretchPoint solve_equilibrium(const Network& net, double force_pN, Positions& x,
                               ConstraintMultipliers& lambda, const StretchOptions& options,
                               const ProgressSink& progress, NewtonPreconditioner* preconditioner);

/// Continuation over the forces (in the given order) from the rest shape.
std::vector<StretchPoint> run_stretch(const Network& net, const std::vector<double>& forces_pN,
                                      const StretchOptions& options,
                                      const ProgressSink& progress = {});

/// Warm re-solve: each force is solved from its entry in `warm` (same network topology,
/// same forces in the same order; std::invalid_argument otherwise), e.g. the equilibria
/// of a run whose parameters differed slightly. A force whose warm solve does not converge
/// is solved again from the previous force's equilibrium of this run (from the rest shape
/// for the first), as the cold continuation would. An empty `warm` is the cold run.
std::vector<StretchPoint> run_stretch(const Network& net, const std::vector<double>& forces_pN,
                                      const StretchOptions& options, const ProgressSink& progress,
                                      const StretchState& warm);

/// The equilibria of a run, to warm-start the next one.
StretchState stretch_state(const std::vector<StretchPoint>& points);

/// Prepared state of repeated sweeps of one mesh over one force list (a parameter scan, a
/// sequence of nearby parameter sets): per force, a Newton preconditioner factorised at that
/// force's equilibrium by the run that first solved it without one (a cold run: one more
/// symbolic analysis, assembly and factorisation per force). A warm run (`warm` = the previous
/// parameters' StretchState) then starts each force's L-BFGS on that force's own
/// preconditioner instead of refactorising at the force start, which is most of a warm
/// re-solve's cost (`rbc bench sweep` rows `discrete/warm13_persistence_1pc/250/1` against
/// `discrete/warm13_persistence_1pc_kept/250`, README). A warm solve leaves the kept
/// factorisation as it was (refactorised only where L-BFGS stalls, refresh_interval), so over
/// many drifting parameter sets it ages: measured at N = 250, persistence x 1.00 -> 1.03 in
/// 1 % steps, 193 pN took 8, 10, then 14 L-BFGS iterations (a plain warm run: 8, with one
/// factorisation). The kept preconditioners serve the next run's network
/// (NewtonPreconditioner::rebind: same mesh, bending law and mirror reduction; otherwise the
/// force refactorises as in the one-shot sweep); a model with custom terms keeps nothing.
/// Results match run_stretch's to the minimiser tolerance but depend on the call history
/// (deterministically), so the calibration keeps to run_stretch. Memory: one Hessian pattern
/// and factor per force (large at the full spectrin level). Another force list or mesh drops
/// what is kept; a force that did not converge keeps nothing.
class StretchSweepSolver {
 public:
  /// Validates the options (rbc::InvalidParameter).
  explicit StretchSweepSolver(const StretchOptions& options = {});
  /// As run_stretch(net, forces_pN, options, progress, warm), keeping each force's
  /// preconditioner for the next run.
  std::vector<StretchPoint> run(const Network& net, const std::vector<double>& forces_pN,
                                const ProgressSink& progress = {}, const StretchState& warm = {});

 private:
  StretchOptions options_;
  SweepScene scene_;                                         ///< what kept_ is for
  std::vector<std::unique_ptr<NewtonPreconditioner>> kept_;  ///< per force of scene_
};

}  // namespace rbc
