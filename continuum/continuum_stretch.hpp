// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Optical-tweezers stretch of the continuum model (MODEL.md sections 2 and 4; paper
// Sec. 5.3.2, Fig. 7): for each force, the constrained equilibrium by sparse Newton
// (continuum/newton_solver.hpp) from the previous one (continuation in force). A force
// whose Newton solve fails is reached through intermediate forces (the increment halved,
// up to max_bisections times) before it is reported as not converged.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "continuum/continuum_model.hpp"
#include "continuum/newton_solver.hpp"
#include "core/lbfgs.hpp"
#include "core/progress.hpp"
#include "core/validation.hpp"
#include "discrete/augmented_lagrangian.hpp"
#include "discrete/stretch_state.hpp"

namespace rbc {

/// Which minimiser: the sparse Newton method (default) or L-BFGS on the augmented
/// Lagrangian (core/lbfgs.hpp; for the benchmark comparison).
enum class ContinuumSolver { newton, lbfgs };
std::string to_string(ContinuumSolver s);

/// With newton.symmetry = mirror and newton.symmetry_check: which symmetric equilibria of a
/// sweep the stability check (core/symmetry_stability.hpp: one full Hessian and |G| - 1
/// sector factorisations) examines.
enum class SymmetryCheckAt {
  /// Each force's, as it is solved (NewtonOptions::symmetry_check): a saddle is left at once.
  every_force,
  /// The highest converged force's only, after the sweep. If it is a saddle, the whole sweep
  /// is run again with every_force, so the answer is then every_force's (and the points count
  /// both passes' work). This rests on buckling growing with the stretch: measured for the soft
  /// corner of the calibration's prior (p = 25 nm, Lmax = 364 nm), once broken at 67.6 pN the
  /// symmetry stayed broken at every higher force, and no lower force of a sweep whose top force
  /// was stable was found unstable (calibrate/forward_model.hpp, check_symmetry_at_top_force,
  /// which the calibration uses). A sweep whose forces are not all below its highest one's
  /// buckling force is then checked in one set of sector factorisations instead of one per
  /// force (13 Mills forces at 980 elements, mirror-planes: 7 against 91).
  highest_force,
};
std::string to_string(SymmetryCheckAt s);

/// How the bead force is applied: to the model's vertex patch (ContinuumModel::patch, whole
/// vertices; default), or as a uniform traction on caps of the prescribed area integrated
/// exactly over partial elements (continuum/contact_load.hpp; the model's patch is replaced
/// for the run).
enum class ContinuumLoad { vertex_patch, exact_contact };
std::string to_string(ContinuumLoad l);
/// How D_A and D_T are measured: the extent of the vertices (core/geometry.hpp
/// measure_diameters; default) or of the quadric-fitted surface (continuum/surface_extent.hpp).
enum class ContinuumMeasure { vertices, quadric_fit };
std::string to_string(ContinuumMeasure m);

struct ContinuumOptions {
  ContinuumSolver solver = ContinuumSolver::newton;
  NewtonOptions newton;
  int max_bisections = 6;  ///< halvings of a failing force increment
  /// Newton iterations one requested force may use over all its sub-steps (bisection and a
  /// failed warm start included); the force is then reported as not converged.
  int max_iterations_per_force = 400;
  /// Wall-clock budget of one requested force (s), sub-steps included; 0 = none.
  double time_budget_s = 0.0;
  /// Polled once per force and sub-step (and by Newton once per iteration when
  /// newton.cancel is empty); returning true stops the run by throwing Cancelled.
  CancelCheck cancel;
  /// With newton.symmetry = mirror and newton.symmetry_check (Newton only): which equilibria
  /// are checked to be minima of the full problem.
  SymmetryCheckAt symmetry_check_at = SymmetryCheckAt::every_force;
  /// Whether each point carries its per-element fields (ContinuumStretchPoint::fields: I1, I2,
  /// principal tensions; what `rbc stretch --out` writes). Off for loops that read only the
  /// diameters and states, e.g. repeated warm re-solves: the fields cost ~8 % of a kept warm
  /// re-solve at 1,000 elements. Off: fields stays empty.
  bool element_fields = true;
  /// L-BFGS only: per-vertex force tolerance (pN), iterations per multiplier update, and
  /// augmented-Lagrangian penalty stiffnesses (pN/um^3, pN/um^5), multiplier updates.
  LbfgsOptions lbfgs;
  double lbfgs_area_stiffness = 100.0, lbfgs_volume_stiffness = 100.0;
  int lbfgs_outer_iterations = 40;
  /// L-BFGS only: penalty schedule of the augmented-Lagrangian driver
  /// (discrete/augmented_lagrangian.hpp), the same as the discrete stretch's.
  AugmentedLagrangianSchedule lbfgs_schedule;
  /// Whether forces above kMaxContinuumForce_pN are accepted (still finite and >= 0): only for
  /// studies of where the model and solver stop working (`rbc stability`). Off: validate(forces)
  /// refuses them, so every front end keeps to the documented range.
  bool beyond_documented_force_range = false;
  ContinuumLoad load = ContinuumLoad::vertex_patch;
  /// ContinuumLoad::exact_contact only: each bead's contact cap as a fraction of the rest
  /// area (TweezersParameters::contact_fraction's meaning; in (0, 0.5)).
  double exact_contact_fraction = 0.05;
  ContinuumMeasure measure = ContinuumMeasure::vertices;
  ContinuumOptions() {
    lbfgs.force_tolerance = 1e-3;
    lbfgs.max_iterations = 20000;
    lbfgs.max_step = 0.1;
  }
  /// Throws rbc::InvalidParameter naming the value: newton.validate(), bisections in [0, 30],
  /// lbfgs.validate(), L-BFGS updates in [1, 10000], penalty stiffnesses finite and > 0,
  /// exact_contact_fraction finite in (0, 0.5).
  void validate() const;
  /// validate() and every force: finite and in [0, kMaxContinuumForce_pN] pN
  /// (validate_continuum_force), or finite and >= 0 with beyond_documented_force_range. Called
  /// by run_continuum_stretch and ContinuumSweepSolver::run before any work, so every front end
  /// (CLI, calibration, Python) is held to the same limits.
  void validate(const std::vector<double>& forces_pN) const;
};

/// Largest total bead force (pN) the continuum stretch is documented to handle, for every
/// order of the law, checked by ContinuumOptions::validate(forces) (validate_continuum_force)
/// before any work. Measured
/// (rbc stretch --model continuum --elements 500, Release, 1 thread): by continuation
/// 0, 100, ..., 400 pN every order (2, 4, full) converges in <= 26 Newton iterations per force
/// and from the rest shape straight to 400 pN in 28-34; from 500 pN each force needs 130-240
/// iterations (12-30 s at 500 elements, 10-25x more), the p = 2 law stretches links past Lmax
/// (README, `rbc stability`), and 2,000 pN took 378 s and 7,752 iterations before failing.
inline constexpr double kMaxContinuumForce_pN = 400.0;

/// Throws rbc::InvalidParameter ("force (continuum model) must be finite and in [0, 400] pN,
/// got ...") unless the force is finite and in [0, kMaxContinuumForce_pN].
inline void validate_continuum_force(double force_pN) {
  require_finite_in_range("force (continuum model)", "pN", force_pN, 0.0, kMaxContinuumForce_pN,
                          Ends::closed_closed);
}

/// One equilibrium of the stretch.
struct ContinuumStretchPoint {
  double force_pN = 0;
  double axial_um = 0, transverse_um = 0;  ///< D_A = max x - min x, D_T = max y - min y
  double energy_pNum = 0;                  ///< E = in-plane + bending - tweezers work
  int iterations = 0;                      ///< Newton (or L-BFGS) iterations, all sub-steps
  int substeps = 1;                        ///< forces solved to reach this one
  /// Numeric factorisations (Newton's, with shift retries, and the symmetry check's sector
  /// ones) and Krylov-correction CG iterations, all sub-steps: the solver's work.
  int factorisations = 0, krylov_iterations = 0;
  bool converged = false;
  NewtonStatus status = NewtonStatus::max_iterations;  ///< to_string(status): in words
  double residual_pN = 0;                              ///< largest net vertex force at the end
  double area_drift = 0, volume_drift = 0;             ///< relative
  double wall_s = 0;
  int vertices = 0, elements = 0;
  ConstraintMultipliers multipliers;  ///< tension-like lambda_A, pressure-like lambda_V
  Positions x;                        ///< equilibrium positions (um)
  ElementFields fields;               ///< per-element I1, I2, principal tensions
  bool warm = false;                  ///< solved from a given StretchState entry
  /// NewtonOptions::symmetry = mirror: the order of the mirror group of the last solve (1 =
  /// solved in full) and whether its symmetric state was unstable (then solved in full).
  int symmetry_order = 1;
  bool symmetry_broken = false;
};

/// Continuation over the forces (pN, in the given order) from the rest shape.
std::vector<ContinuumStretchPoint> run_continuum_stretch(const ContinuumModel& model,
                                                         const std::vector<double>& forces_pN,
                                                         const ContinuumOptions& options,
                                                         const ProgressSink& progress = {});

/// Warm re-solve: each force is solved by Newton from its entry in `warm` (same mesh, same
/// forces in the same order; std::invalid_argument otherwise), e.g. the equilibria of a
/// run whose law parameters differed slightly. A force whose warm solve fails is reached
/// from the previous force's equilibrium of this run by the cold continuation (with
/// bisection). An empty `warm` is the cold run.
std::vector<ContinuumStretchPoint> run_continuum_stretch(const ContinuumModel& model,
                                                         const std::vector<double>& forces_pN,
                                                         const ContinuumOptions& options,
                                                         const ProgressSink& progress,
                                                         const StretchState& warm);

/// The equilibria of a run, to warm-start the next one.
StretchState stretch_state(const std::vector<ContinuumStretchPoint>& points);

/// Per force of a sweep, a Newton method holding a factorisation at that force's last
/// equilibrium (ContinuumSweepSolver), and the symmetry reduction they were made under.
struct KeptMethods {
  std::vector<std::optional<ShiftedNewton>> per_force;
  std::vector<int> group;  ///< NewtonSolver::symmetry_group() of the runs that made them
  /// The solver of the last run, pointed at the next run's model when it has the same mesh
  /// (NewtonSolver::rebind): its patterns, analyses and symmetry set-up are made once.
  std::unique_ptr<NewtonSolver> solver;
};

/// Prepared state of repeated sweeps of one mesh over one force list (a parameter scan, a
/// sequence of nearby parameter sets): per force, the Newton method with the factorisation
/// at that force's last equilibrium (made there after a cold solve, one factorisation more per
/// force; after a warm solve on it, the one that solve ended with). A warm run (`warm` = the
/// previous parameters' StretchState) then starts each force with chord steps on that force's
/// own factorisation instead of factorising afresh, which is most of a warm re-solve's cost
/// (measured at 980 elements, 13 Mills forces, persistence + 1 %: `rbc bench sweep` rows
/// `continuum/warm13_persistence_1pc/1000/{0,1}` against `..._kept/...`, README). Results
/// match run_continuum_stretch's to the solver tolerance but depend on the call history
/// through the kept factorisations (deterministically); hence the calibration, whose likelihood
/// must depend on (theta, warm) alone, keeps to run_continuum_stretch. Memory: one factor
/// per force (about 1 MB per force at 1,000 elements). The Newton solver itself (its Hessian
/// patterns, symbolic analyses, mirror reductions and stability sectors) is kept too while the
/// mesh stays, and each run starts it as new (NewtonSolver::rebind). Another force list, mesh
/// (vertex count, faces) or symmetry reduction (bead patch) drops what is kept; a force that did
/// not converge, or whose equilibrium is not symmetric under Symmetry::mirror, keeps nothing. Only
/// the Newton solver with reuse_across_solves keeps anything (else as the one-shot sweep).
class ContinuumSweepSolver {
 public:
  /// Validates the options (rbc::InvalidParameter).
  explicit ContinuumSweepSolver(const ContinuumOptions& options = {});
  /// As run_continuum_stretch(model, forces_pN, options, progress, warm), keeping each force's
  /// factorisation for the next run.
  std::vector<ContinuumStretchPoint> run(const ContinuumModel& model,
                                         const std::vector<double>& forces_pN,
                                         const ProgressSink& progress = {},
                                         const StretchState& warm = {});

 private:
  ContinuumOptions options_;
  SweepScene scene_;  ///< what kept_ is for
  KeptMethods kept_;  ///< per force of scene_
};

/// One equilibrium at force F from x (updated) and lambda (updated) with L-BFGS inside the
/// augmented-Lagrangian driver (discrete/augmented_lagrangian.hpp; penalties
/// lbfgs_area_stiffness, lbfgs_volume_stiffness, schedule lbfgs_schedule, at most
/// lbfgs_outer_iterations updates); returns the same summary as Newton's. A failed line
/// search or an infeasible start is reported as such; spent updates as max_iterations.
NewtonResult solve_equilibrium_lbfgs(const ContinuumModel& model, double force_pN, Positions& x,
                                     ConstraintMultipliers& lambda,
                                     const ContinuumOptions& options);

}  // namespace rbc
