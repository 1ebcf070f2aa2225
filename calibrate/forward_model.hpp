// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The forward model of the calibration: optical-tweezers diameters D_A(F), D_T(F) at the
// data's forces for one set of physical parameters, by the discrete network or the
// continuum model (compare/methods.hpp's Method), warm-started from a parent's equilibria.
//
// A run solves the forces in increasing order. Force k starts from the warm state's
// equilibrium at force k (the parent sample's, when given) and otherwise from this run's
// equilibrium at force k-1 (continuation in force; the rest shape for the first). A failed
// solve (not converged, infeasible) is retried from this run's previous equilibrium through
// intermediate forces, the increment halved up to `retry_bisections` times; if that fails
// too the run fails (the sampler counts it as zero likelihood).
//
// Thread safety: run() may be called from many threads at once; each call borrows a private
// workspace (a copy of the model and its solver) from a pool. The result depends only on
// (parameters, warm state): solvers keep no state between calls and their inner parallel
// regions must run on one thread (calibrate/tmcmc.hpp's executors see to it), since
// OpenMP reductions over a different thread count sum in a different order.
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "calibrate/likelihood.hpp"
#include "calibrate/tmcmc.hpp"
#include "compare/methods.hpp"
#include "continuum/newton_solver.hpp"

namespace rbc {

/// Physical parameters of a forward run, natural units. Defaults: paper Tables 1-2
/// (Lbar = 75 nm fixed, T = 300 K, q = 1, eta = 0.005, H0 = 0).
struct ForwardParameters {
  double persistence_nm = 7.5;
  double lmax_nm = 237.75;
  double kappa_J = 2e-19;
  double contact_fraction = 0.05;
  void validate() const;  ///< p > 0, Lmax > 75 nm, kappa > 0, fraction in (0, 0.5)
};

/// Sets a network's parameter-dependent parts to `p` as the forward model's discrete runs do:
/// the full WLC density and its steric constant, Juelicher's kappa and the matched dihedral
/// stiffness, and the smooth bead patch of the contact fraction (calibrate/smooth_patch.hpp).
void apply_forward_parameters(Network& net, const ForwardParameters& p);
/// The same for a continuum model: the in-plane law of `order` from the WLC parameters, kappa
/// and the smooth bead patch.
void apply_forward_parameters(ContinuumModel& m, const ForwardParameters& p, WlcExpansion order);

/// The largest force the model of `kind` is documented to handle (pN): kMaxDiscreteForce_pN or
/// kMaxContinuumForce_pN.
double max_method_force_pN(MethodKind kind);
/// Throws rbc::InvalidParameter ("force (continuum model) must be finite and in [0, 400] pN,
/// got 1000 pN") unless the force is finite and in [0, max_method_force_pN(kind)].
void validate_method_force(MethodKind kind, double force_pN);

struct ForwardOptions {
  /// Default continuum:2:2000 (calibrate/infer.hpp documents why).
  Method method{MethodKind::continuum, 2000, WlcExpansion::order2};
  std::vector<double> forces_pN;  ///< increasing, >= 0
  /// Warm start at force k > 0 from the parent's equilibrium there plus this run's
  /// correction at force k - 1 (x_k(theta) - x_k(parent) ~ x_{k-1}(theta) - x_{k-1}(parent):
  /// the parameter change's displacement field varies slowly with the force). Measured
  /// (2,000 elements, paper parameters, p x 1.01): initial residuals 3-7x smaller than from
  /// the parent's equilibrium alone, so most forces converge in one Newton iteration. A
  /// predicted start that fails is followed by the parent's plain equilibrium.
  bool predict_from_previous_force = true;
  /// Halvings of the force increment on a retry: 2, 4, ..., 2^b sub-steps (at most 14
  /// extra solves per force at the default 3).
  int retry_bisections = 3;
  /// Continuum Newton settings: converged at a largest net vertex force of 1e-4 pN (the
  /// library default 1e-6 pN sits at the round-off floor of soft networks: p = 40 nm stalled
  /// at 1.4e-6 pN, Lmax = 110 nm at 3.3e-5 pN; 1e-4 pN moves a diameter by ~1e-4 um), area and
  /// volume to 1e-6 (below), at most 40 iterations in the first pass of a solve (a warm start
  /// converges in 2-5, a continuation step in 5-9).
  NewtonOptions newton = default_newton();
  static NewtonOptions default_newton() {
    NewtonOptions n;
    n.max_iterations = 40;
    n.force_tolerance_pN = 1e-4;
    // Area and volume to 1e-6 relative (library default 1e-10): moves a diameter by ~1e-6
    // relative, 1e-4 of the force tolerance's effect, and spares the second Newton iteration
    // that the nonlinear constraints alone needed after a warm step (drift 1e-7-1e-6).
    n.constraint_tolerance = 1e-6;
    // Warm starts converge in 2-3 iterations: one factorisation per force without a shift
    // (1e-8 as without the correction), chord steps on it whose Krylov correction undoes
    // only a shift the factorisation needed (lagged Hessian: chord steps assemble nothing).
    // Measured (2,000 elements, one core): paper parameters' warm sweep as fast as without
    // the correction; p = 25 nm, Lmax = 364 nm 13 forces converged in 4-5 iterations each
    // where the shift alone needed 40-200 and failed at 151 pN.
    n.krylov_initial_shift = 1e-8;
    n.krylov_max_factor_reuse = 4;
    n.krylov_lagged_hessian = true;
    n.reuse_across_solves = false;
    // On the mirror-symmetric states (continuum/newton_solver.hpp), checked once per run at
    // the highest force (check_symmetry_at_top_force) rather than at every force.
    n.symmetry = Symmetry::mirror;
    n.symmetry_check = false;
    return n;
  }
  /// With newton.symmetry = mirror: after a run whose equilibria are symmetric, check that the
  /// one at the highest force is a minimum of the full problem (one full Hessian and |G| - 1
  /// sector factorisations, ~10 % of a warm run). If it is a saddle (the cell buckles: soft
  /// cells far out in the prior box, e.g. p = 25 nm, Lmax = 364 nm from ~50 pN on), the first
  /// unstable force is found by bisection over the forces (log2 of their number in checks) and
  /// the forces from it on are solved again with every equilibrium checked: the saddle is
  /// pushed 1e-3 um along its unstable sector and solved in full, and the later forces
  /// continue from the buckled state in full (continuum/newton_solver.hpp). The forces below
  /// keep their symmetric equilibria. Buckling grows with the stretch: in the soft cell
  /// measured, once broken at 67.6 pN the symmetry stayed broken at every higher force, and
  /// no lower force of a run whose top force was stable was found unstable (tested on the
  /// recovery test's and the default prior's corners).
  bool check_symmetry_at_top_force = true;
  /// Slow but converging solves (continuum). Soft networks far out in the prior box (e.g.
  /// p = 25 nm, Lmax = 364 nm at 100 pN, D_A = 26 um) carry a large membrane tension lambda_A
  /// whose constraint curvature lambda_A d2A makes d2L indefinite; the solver's shift then
  /// turns Newton into a linearly converging iteration (measured contraction 0.84-0.97 per
  /// iteration at 200 elements), which no smaller force step cures. A solve that reaches the
  /// first pass's iteration limit is therefore continued in passes of `pass_iterations`
  /// Newton iterations, up to `max_total_iterations`, while its residual keeps falling, and
  /// accepted when either the force tolerance is met or the diameters have converged: the
  /// geometric tail d q/(1 - q) of the change d of D_A and D_T over the last pass (q = ratio
  /// of the last two passes' changes, q <= max_contraction) is below diameter_tolerance_um and
  /// the residual below accept_residual_pN. Defaults: 1e-3 um is 0.21 % of the smallest error
  /// bar of the bundled stretch data (0.482 um, data/README.md), 2 % of the recovery test's noise
  /// (0.05 um) and 1/30 of the model error of 2,000 elements; measured at p = 25 nm, Lmax =
  /// 364 nm, 100 pN (200 elements) the diameters at a 1e-3 pN residual are 1.4e-3 um from
  /// the 1e-9 pN ones. A solve that stops falling, fails its line search or exhausts the
  /// budget fails (and is retried in smaller force steps as before).
  int pass_iterations = 10;
  int max_total_iterations = 200;
  double diameter_tolerance_um = 1e-3;
  double accept_residual_pN = 1e-2;
  double max_contraction = 0.9;
  /// Throws std::invalid_argument (rbc::InvalidParameter for a force) unless the forces are
  /// increasing and each finite and in [0, max_method_force_pN(method.kind)], the resolution
  /// > 0, newton.validate() and the pass settings are consistent.
  void validate() const;
};

/// One forward run.
struct ForwardRun {
  ModelDiameters diameters;  ///< at options.forces_pN
  bool converged = false;    ///< every force converged
  bool retried = false;      ///< some force needed the retry
  /// Forces accepted at the diameter tolerance (ForwardOptions) rather than the force one.
  int diameter_converged = 0;
  double residual_pN = 0;  ///< largest final residual over the forces
  /// Some equilibrium of the run is not mirror-symmetric: the symmetric ones were saddles from
  /// some force on (check_symmetry_at_top_force) and those forces were solved again in full,
  /// or a buckled parent's start was followed in full.
  bool symmetry_broken = false;
  WarmState state;  ///< per force: 3N positions (um) and two multipliers
  // Diagnostics of a failed run (empty/zero when converged):
  double failed_force_pN = 0;  ///< the force that failed after every retry
  std::string failure;         ///< solver status and residual of the last attempt, in words
  int solves = 0;              ///< equilibrium solves made (warm, continuation and retries)
};

/// Sets OpenBLAS (CHOLMOD's BLAS) to one thread, process-wide (defensive: OpenBLAS takes its
/// thread count from OMP_NUM_THREADS when it loads and does not follow the one-thread inner
/// regions, so a factorisation could sum in an order that depends on OMP_NUM_THREADS; the
/// difference measured at 1e-12 in the log-evidence came from the rest mesh, built on one
/// thread now). With forward solves run one per thread, BLAS threads buy nothing.
/// `rbc infer` calls it (every MPI rank); run_inference() holds the same setting for its own
/// duration only (core/blas_threads.hpp, ScopedProcessBlasThreads), so a library caller's BLAS
/// gets its threads back. A no-op when the BLAS is not OpenBLAS. OpenMP's thread count is left
/// as it was (OpenBLAS's OpenMP build changes it too).
void use_single_threaded_blas();

class ForwardModel {
 public:
  explicit ForwardModel(const ForwardOptions& options);
  ~ForwardModel();
  ForwardModel(const ForwardModel&) = delete;
  ForwardModel& operator=(const ForwardModel&) = delete;

  /// Diameters at the forces for the parameters, from the warm state (empty = cold start
  /// from the rest shape; otherwise it must come from this model).
  ForwardRun run(const ForwardParameters& parameters, const WarmState& warm = {}) const;
  /// As above, reporting every solve (force, start, status, iterations, residual) and the
  /// solver's own iterations to `trace` (`rbc infer --forward-check --trace`).
  ForwardRun run(const ForwardParameters& parameters, const WarmState& warm,
                 const ProgressSink& trace) const;

  const ForwardOptions& options() const { return options_; }
  int vertices() const;
  int elements() const;

 private:
  struct Workspace;
  struct Shared;
  std::unique_ptr<Workspace> borrow() const;
  void give_back(std::unique_ptr<Workspace> ws) const;
  ForwardOptions options_;
  std::unique_ptr<Shared> shared_;
  mutable std::mutex pool_mutex_;
  mutable std::vector<std::unique_ptr<Workspace>> pool_;
};

}  // namespace rbc
