// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Sparse Newton method for the constrained continuum equilibrium (MODEL.md section 4):
//   stationary points of L(x, lambda) = E(x) + lambda_A (A(x) - A0) + lambda_V (V(x) - V0),
// E = in-plane + Helfrich - tweezers work (continuum/continuum_model.hpp). Each iteration
// solves the bordered KKT system
//   [K  C] [dx     ]     [r]     r = dE + C lambda (net vertex forces, pN),
//   [C' 0] [dlambda] = - [c],    c = (A - A0, V - V0),  C = [dA dV],
// by core/shifted_newton.hpp, the project's one shifted Newton method (K = d2L + sigma I
// factorised by supernodal sparse Cholesky, core/sparse_cholesky.hpp; ordering analysed once per
// mesh; the 2 x 2 Schur complement S = C' K^-1 C). Safeguards: sigma >= sigma_min ~ 1e-8 x mean
// diagonal fixes the translation and rotation null modes; when the factorisation is not positive
// definite (indefinite d2L away from a minimum) sigma grows by 10x until it is
// (Levenberg-Marquardt). The step is capped so no vertex moves more than max_step_um, then
// backtracked on the merit
//   phi = E + lambda_new'c + (rho/2) sum_k (c_k/G_k)^2   (rho = penalty_pNum, G = A0, V0),
// along which the KKT direction is always a descent direction (phi' = -dx'K dx - rho |c/G|^2).
// A trial step that collapses or flips an element (J < kCollapsedElementRatio, or a face
// normal turning by more than 90 degrees within one step) is infeasible and halved,
// so no NaN ever enters the iterate.
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "continuum/block_hessian.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/reduced_hessian.hpp"
#include "continuum/symmetric_energy.hpp"
#include "core/mirror_symmetry.hpp"
#include "core/progress.hpp"
#include "core/reduced_problem.hpp"
#include "core/shifted_newton.hpp"
#include "core/symmetry_stability.hpp"
#include "discrete/constraint_energy.hpp"
#include "discrete/newton_preconditioner.hpp"

namespace rbc {

struct NewtonOptions {
  double force_tolerance_pN = 1e-6;     ///< converged when the largest net vertex force is below
  double constraint_tolerance = 1e-10;  ///< ... and |A - A0|/A0, |V - V0|/V0 are below
  int max_iterations = 100;             ///< Newton iterations per solve
  double max_step_um = 1.0;             ///< largest vertex displacement of one Newton step
  int max_line_search = 40;             ///< step halvings before the line search fails
  double penalty_pNum = 1e4;            ///< rho of the merit function (pN um)
  /// Chord steps: consecutive iterations that may reuse the last factorisation of K while
  /// each full step still cuts the net force fourfold (0 = plain Newton).
  int max_factor_reuse = 4;
  /// A factorisation is reused only while each step cuts the net force by this factor.
  double reuse_contraction = 0.25;
  /// Factorise K by CHOLMOD's simplicial LL' (no BLAS) below this many unknowns (3N),
  /// supernodal LL' (BLAS dgemm) from it on. 0 = always supernodal: measured (note_speed.md)
  /// twice as fast as simplicial already at 1,500 unknowns once BLAS runs on one thread.
  int supernodal_min_unknowns = 0;
  /// Fill-reducing ordering, analysed once per mesh. METIS: measured at 980 elements
  /// 14 % fewer factor nonzeros and 26 % less factorisation time than CHOLMOD's automatic
  /// choice (AMD there).
  FillOrdering ordering = FillOrdering::metis;
  /// BLAS threads of the factorisation and solves (core/blas_threads.hpp); 0 = the caller's.
  /// One by default: CHOLMOD's many small BLAS calls scale poorly (thread wake-ups) and one
  /// thread keeps the rounding independent of the core count.
  int blas_threads = 1;
  /// Precision of the factorisation of K = d2L + shift (core/sparse_cholesky.hpp). Single by
  /// default: with the Krylov correction (krylov_iterations > 0, the default)
  /// the factor only preconditions the CG on the double d2L, so the steps, iterations and
  /// equilibria are those of the double factor (9,680 elements, 0 and 88 pN: the same 5 and 9
  /// iterations, diameters within 4e-12 relative), and the factorisation runs at the float
  /// kernels' rate (88 pN from 0 pN: 0.80 -> 0.40 s). Where the correction does not run on
  /// every step a float factor would make those steps inexact, so the factorisation is then
  /// in double whatever this says: krylov_iterations = 0, or krylov_initial_shift at or below
  /// the correction's kept shift (1e-8; calibrate's forward model), whose lagged chord steps
  /// skip the correction. The mirror-sector stability checks always factorise in double.
  SolvePrecision factor_precision = SolvePrecision::single_precision_factorisation;
  /// Keep the last factorisation between solve() calls (continuation in force, warm
  /// re-solves): the first iteration of the next solve is a chord step on it (with the
  /// Krylov correction an exact Newton step preconditioned by it). On by default since the
  /// Krylov correction (measured at 980 elements, 13 Mills forces: 13 instead of 24
  /// factorisations); the results then depend on the solver's call history (deterministically:
  /// run_continuum_stretch makes one solver per sweep; reuse a solver across different
  /// models or parameters only after forget_factorisation()).
  bool reuse_across_solves = true;
  /// Krylov correction (core/shifted_newton.hpp; 0 = off): up to this many projected CG
  /// iterations per Newton iteration make each step the exact Newton step of d2L on the
  /// area/volume tangent space, preconditioned by the (shifted or kept) factorisation. Newton
  /// then stays quadratic where a Levenberg shift is needed (soft cells at high tension:
  /// lambda_A d2A makes d2L indefinite), and a factorisation serves up to max_factor_reuse
  /// further iterations while each correction needs at most krylov_refactor_iterations.
  int krylov_iterations = 50;
  /// Relative error of the step in the factor's norm. 1e-3 measured as fast as 1e-6 in
  /// Newton iterations (60 vs 63 over the 13 Mills forces at 980 elements) with fewer CG
  /// iterations; Newton still converges quadratically to the tolerance's last digits.
  double krylov_tolerance = 1e-3;
  int krylov_refactor_iterations = 10;
  /// Chord steps correct only the shift of the last factorised d2L and assemble nothing
  /// (core/shifted_newton.hpp krylov_lagged_hessian).
  bool krylov_lagged_hessian = true;
  /// ... but once a step of a solve was backtracked or a factorisation needed a larger shift,
  /// the rest of that solve corrects with the current d2L (core/shifted_newton.hpp
  /// krylov_exact_when_far). Measured (1 thread, same equilibria): 8 forces 0-193 pN at 5,120
  /// elements, 51 Newton iterations and 7 factorisations against 61 and 34 (6 of them failed)
  /// with the lagged Hessian throughout, 1.34x less CPU; the 13 Mills forces at 980 elements,
  /// 70 and 9 against 83 and 31 (1.13x less CPU without the symmetry, the same with it); at
  /// 500-3,920 elements iterations and factorisations equal or fewer, CPU the same within
  /// noise.
  bool krylov_exact_when_far = true;
  /// CG iterations of a correction on the lagged Hessian (core/shifted_newton.hpp
  /// krylov_lagged_iterations; 0 = up to krylov_iterations). Measured (2 threads, same
  /// equilibria to the tolerance; `rbc bench sweep`): the warm re-solve on kept
  /// factorisations of the 13 Mills forces at 980 elements after p + 1 %, 40 Newton and 40 CG
  /// iterations against 42 and 57 with up to 50 (where a lagged correction needed 3-4 CG
  /// iterations its step was worse than the shifted one and was backtracked); cold sweeps
  /// take a few more Newton iterations (13 forces at 980 elements: 77 against 69) but fewer
  /// solves, and were 10-30 % faster (980 to 9,680 elements).
  int krylov_lagged_iterations = 1;
  /// Chord steps on the lagged Hessian keep K^-1 C of the factorisation's first step
  /// (core/shifted_newton.hpp krylov_lagged_constraints). Measured (2 threads, `rbc bench
  /// sweep`, two alternating runs): the kept warm re-solve at 980 elements 0.031-0.034 ->
  /// 0.026 s (40 Newton iterations either way); 8 forces at 5,120 elements 51 -> 46 Newton
  /// iterations, 0.89-1.04 -> 0.85-0.91 s; 13 forces at 980 elements 77 -> 75 iterations, the
  /// same time within noise.
  bool krylov_lagged_constraints = true;
  /// With the correction, the shift's start (x mean diagonal; replaces 1e-8): a shift the
  /// correction undoes costs a few CG iterations, a failed factorisation a whole one.
  double krylov_initial_shift = 1e-4;
  /// With the correction, the chord steps per factorisation (replaces max_factor_reuse).
  int krylov_max_factor_reuse = 20;
  /// Symmetry::mirror: solve on the configurations symmetric under the mirrors the mesh and
  /// the bead load share (discrete/tweezers.hpp tweezers_scene_symmetry; 4 on the default
  /// meshes, see core/mirror_symmetry.hpp), with |G| times fewer unknowns. The result is a
  /// critical point of the full problem (its reported residual is the full one, evaluated at
  /// the end), but a symmetric equilibrium may be a saddle where the cell would buckle: an
  /// option, not the default.
  Symmetry symmetry = Symmetry::none;
  /// With Symmetry::mirror: after each converged symmetric solve, check that the state is a
  /// minimum of the full problem (core/symmetry_stability.hpp: one full Hessian and |G| - 1
  /// sector factorisations); where it is not (the cell buckles: measured for a soft cell,
  /// p = 25 nm, Lmax = 364 nm, at 67.6 pN, the y -> -y mirror breaks by 0.48 um), the state
  /// is pushed 1e-3 um along the unstable sector and solved in full (pushed 10x and 100x
  /// farther where that solve ends unconverged or within the push of the saddle, as it can just
  /// past the bifurcation, where the landscape is flat). A start that is itself
  /// not symmetric (a buckled state of the previous force) is solved in full. Off: trust the
  /// symmetry (faster; a saddle is then reported as an equilibrium).
  bool symmetry_check = true;
  /// Polled once per Newton iteration; returning true stops the solve by throwing Cancelled.
  CancelCheck cancel;
  /// Throws rbc::InvalidParameter: force tolerance finite in (0, 10] pN, constraint tolerance in
  /// (0, 1), max_iterations in [1, kMaxIterations], line search in [1, 1000], reuse in
  /// [0, 1000], contraction in (0, 1), step in (0, 10] um, penalty finite and >= 0.
  void validate() const;
};

// NewtonStatus (converged, max_iterations, line_search_failed, infeasible_start,
// time_budget, factorisation_failed) and to_string(NewtonStatus): core/shifted_newton.hpp.

/// Per-call limits tighter than the options (a continuation's remaining budget).
struct NewtonLimits {
  int max_iterations = -1;  ///< < 0: options.max_iterations
  /// Stop with NewtonStatus::time_budget once this time has passed (checked per iteration).
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
};

struct NewtonResult {
  NewtonStatus status = NewtonStatus::max_iterations;
  int symmetry_order = 1;  ///< order of the mirror group the solve was reduced by (1: full)
  /// Symmetry::mirror: the answer is not mirror-symmetric (the symmetric state was a saddle,
  /// or the start was already a buckled state; both solved in full).
  bool symmetry_broken = false;
  int stability_factorisations = 0;  ///< sector factorisations of the symmetry check
  int iterations = 0;
  int factorisations = 0;                   ///< including retries with a larger shift
  int chord_steps = 0;                      ///< iterations that reused an earlier factorisation
  int krylov_iterations = 0;                ///< CG iterations of the Krylov correction
  int krylov_fallbacks = 0;                 ///< iterations that took the shifted step
  double residual_pN = 0;                   ///< largest net vertex force |dE + C lambda| at the end
  double area_drift = 0, volume_drift = 0;  ///< (A - A0)/A0, (V - V0)/V0 at the end
  double energy_pNum = 0;                   ///< E (without constraint terms) at the end
  double largest_shift = 0;                 ///< largest sigma used relative to the mean diagonal
  bool converged() const { return status == NewtonStatus::converged; }
};

/// Owns the prepared state of the Newton method for one model: the Hessian pattern and
/// the symbolic factorisation (analysed once, reused for every force).
class NewtonSolver {
 public:
  NewtonSolver(const ContinuumModel& model, const NewtonOptions& options);
  /// Solves for the equilibrium at bead force F (pN) from x (3 x N, updated in place) and
  /// the multipliers (updated). Never leaves x at an infeasible or NaN state.
  NewtonResult solve(double force_pN, Positions& x, ConstraintMultipliers& lambda,
                     const ProgressSink& progress = {}, const NewtonLimits& limits = {});
  /// Whether `model` has this solver's mesh (the same rest positions and faces, compared with
  /// the solver's own copy: the model it was bound to may be gone): then rebind() may point
  /// the solver at it.
  bool same_mesh(const ContinuumModel& model) const;
  /// Points the solver at `model` (another law, bending or bead patch on the same mesh;
  /// std::invalid_argument unless same_mesh) and drops the kept factorisations. What depends
  /// on the mesh alone stays: the Hessian patterns and their symbolic analyses, the mirror
  /// group and its reductions, the stability check's sectors. The next solve then runs as on a
  /// new solver for `model`, bit for bit, without their set-up. `model` must outlive the use.
  void rebind(const ContinuumModel& model);
  /// Drops the factorisations kept for reuse_across_solves (the next solve factorises afresh).
  void forget_factorisation() {
    newton_.forget_factorisation();
    if (full_newton_) full_newton_->forget_factorisation();
  }
  /// A copy of the Newton method of the main problem (the symmetric one with
  /// Symmetry::mirror, else the full one), its factorisation included; and the exchange of it
  /// with a kept one (ContinuumSweepSolver: one per force). The states off the symmetric ones
  /// (buckled) are solved by another method, which is neither copied nor exchanged.
  ShiftedNewton copy_method() const { return newton_.clone(); }
  void swap_method(ShiftedNewton& kept) noexcept { newton_.swap(kept); }
  /// The mirrors the solves are reduced by (indices into the rest mesh's group; {0} or empty
  /// for the full problem): methods kept under another group must not be swapped in.
  const std::vector<int>& symmetry_group() {
    if (options_.symmetry == Symmetry::mirror) update_reduction();
    return reduced_group_;
  }
  /// Symmetry::mirror: whether the symmetric equilibrium x (3 x N, um) at force F with its
  /// multipliers is a minimum of the full problem (core/symmetry_stability.hpp; one full
  /// Hessian and |G| - 1 sector factorisations). Always stable without a reduction or for a
  /// state that is not symmetric (a full solve's).
  SectorStability check_symmetric_state(double force_pN, const Positions& x,
                                        const ConstraintMultipliers& lambda);
  /// Turns NewtonOptions::symmetry_check on or off for the next solves (a sweep that checks
  /// only its highest force, continuum/continuum_stretch.hpp SymmetryCheckAt).
  void set_symmetry_check(bool on) { options_.symmetry_check = on; }
  /// Order of the mirror group the solves are reduced by (1: the full problem).
  int symmetry_order() const { return reduction_ ? reduction_->group_order : 1; }
  /// Factorises the Hessian of the main problem (see copy_method) at x (3 x N, um) with
  /// multipliers lambda at force F (pN) and holds it for the next solve (reuse_across_solves):
  /// e.g. at an equilibrium, for re-solves near it. Adds the factorisations made to
  /// *factorisations (if given). False, and nothing done, when x is not a state of the main
  /// problem (not symmetric with Symmetry::mirror); false too when no shift made K definite.
  bool factorise_at(double force_pN, const Positions& x, const ConstraintMultipliers& lambda,
                    int* factorisations = nullptr);

 private:
  /// The problem a solve from x at force F works on: the full one, and the one solved (the
  /// symmetric reduction of it, unless x is not symmetric), its start and its method.
  struct Prepared {
    NewtonProblem full, pb;
    Eigen::VectorXd xf;  ///< the start in pb's unknowns
    bool reduced = false;
    ShiftedNewton* method = nullptr;
  };
  Prepared prepare(double force_pN, const Positions& x);
  const ContinuumModel* model_;  ///< rebind() may point it at another model of the same mesh
  Positions mesh_rest_;          ///< the mesh the solver is prepared for (same_mesh)
  Faces mesh_faces_;
  NewtonOptions options_;
  /// The full Hessian's pattern and values (3N x 3N lower, ~5 MB at 2,562 vertices): built at
  /// its first use, which the mirror path reaches only when a symmetric state is a saddle.
  std::unique_ptr<BlockHessian> hessian_;
  /// The full problem at force F (pN), its Hessian assembled into hessian_ (built lazily).
  NewtonProblem full_problem(double force_pN);
  ShiftedNewton newton_;
  /// Symmetry::mirror: the rest mesh's mirrors (found once), the subgroup the current bead
  /// patch keeps (re-checked every solve: a caller may change model.patch, e.g. the
  /// calibration's contact fraction) and its reduction; null reduction: the full problem.
  MeshSymmetry mesh_symmetry_;
  std::vector<int> reduced_group_{0};
  std::shared_ptr<const SymmetryReduction> reduction_;
  std::shared_ptr<ReducedProblemCache> reduced_cache_;
  std::unique_ptr<ReducedLagrangianHessian> reduced_hessian_;
  /// The energy, gradient and constraints on the symmetric states from the same
  /// representatives (continuum/symmetric_energy.hpp).
  std::shared_ptr<SymmetricContinuumEnergy> symmetric_energy_;
  std::unique_ptr<SymmetryStabilityCheck> stability_;
  std::unique_ptr<ShiftedNewton> full_newton_;  ///< solves that leave the symmetric states
  MeshSymmetry reduced_group_symmetry_;         ///< the group reduction_ is of
  /// The rest mesh's distance from its symmetric part under reduction_ (um, largest
  /// coordinate): ~1e-15 on the project's meshes (rounding).
  double rest_asymmetry_um_ = 0.0;
  void update_reduction();
  /// The sector check at the symmetric state xf (3N) with multipliers l, every sector
  /// assembled from the representative elements. `at_xf`: full's point at xf if the caller
  /// has it (else it is evaluated here).
  SectorStability check_sectors(const NewtonProblem& full, const Eigen::VectorXd& xf,
                                const Eigen::VectorXd& l, const NewtonPoint* at_xf = nullptr);
};

/// The core method's options for the continuum equilibrium (tolerances in pN and relative
/// area/volume, steps in um, penalty in pN um).
ShiftedNewtonOptions shifted_newton_options(const NewtonOptions& o);

/// Terms a caller adds to the continuum objective (the dynamics' dissipation): value with its
/// gradient accumulated into grad (pN um, pN), and the Hessian added into h (pN/um).
struct ContinuumExtraTerms {
  std::function<double(const Positions& x, Positions& grad)> energy;
  std::function<void(const Positions& x, BlockHessian& h)> hessian;
};

/// The continuum equilibrium as a core/shifted_newton.hpp problem over the flat 3N positions:
/// E(x; F) (+ extra) with the area and volume constraints c = (A - A0, V - V0) scaled by
/// (A0, V0), its Hessian d2E (+ extra) + lambda_A d2A + lambda_V d2V assembled into h (which
/// must outlive the problem, as must model and extra), and the face-flip feasibility check.
NewtonProblem continuum_newton_problem(const ContinuumModel& model, double force_pN,
                                       BlockHessian& h, const ContinuumExtraTerms& extra = {});
/// The same, with the Hessian's storage from `storage()` at the first Hessian evaluation (a
/// solver that may never need the full Hessian, as on the mirror-symmetric states, builds
/// its pattern only when it does). `storage` must outlive the problem.
NewtonProblem continuum_newton_problem(const ContinuumModel& model, double force_pN,
                                       std::function<BlockHessian&()> storage,
                                       const ContinuumExtraTerms& extra = {});

/// Rejects a trial state that flips a face: some face normal turns by more than 90 degrees
/// between from and to (flat 3N layouts).
bool any_face_flipped(const Eigen::VectorXd& from, const Eigen::VectorXd& to, const Topology& topo);

/// Largest Euclidean norm over the columns of a 3 x N field (pN for forces).
double largest_vertex_norm(const Positions& v);

}  // namespace rbc
