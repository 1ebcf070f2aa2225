// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The accuracy-cost study behind `rbc stretch --accuracy`: every method and
// resolution stretched over the 13 forces of the stretch data, measured against a reference built
// from the full spectrin level on several rotated triangulations, with the cost of each run in
// equivalent energy+gradient evaluations (CPU time, machine independent to first order).
#include <string>
#include <vector>

#include "compare/methods.hpp"

namespace rbc {

/// The 13 forces of Mills et al. (2004), pN (the default of `rbc stretch`).
const std::vector<double>& mills_forces_pN();

struct AccuracyStudyOptions {
  std::vector<double> forces_pN = mills_forces_pN();
  /// Discrete networks of the table (vertices; icosphere counts 252, 492, 1002, ...).
  std::vector<int> discrete_vertices = {250, 500, 1000, 2000, 4000, 8000, 16000};
  /// Continuum meshes (elements). Two nested icosphere chains, frequency doubling:
  /// f = 5, 10, 20, 40 (500, 2000, 8000, 32000) and f = 7, 14, 28 (980, 3920, 15680).
  std::vector<int> continuum_elements = {500, 980, 2000, 3920, 8000, 15680, 32000};
  std::vector<WlcExpansion> continuum_orders = {WlcExpansion::order2, WlcExpansion::full};
  /// Largest mesh the full law is run on (its sweeps cost about as much as p = 2's).
  int full_law_max_elements = 8000;
  /// Continuum rows on the adapted mesh (Method::adapted: graded to the scene, exact contact
  /// load, quadric-fit diameters): requested element counts (empty = none), each run with
  /// every law of adapted_orders and every coarse / fine size ratio of adapted_size_ratios,
  /// on the mesh seeds 0 .. adapted_seeds - 1 (AdaptedMeshOptions::seed: another
  /// triangulation of the same size field, the analogue of the icosphere's rotations; the
  /// row's errors are the worst over them). The full problem only: the adapted mesh keeps no
  /// mirror of the scene. Their rows are written beside the table's
  /// (accuracy_cost_adapted.csv), not into it.
  std::vector<int> adapted_elements;
  std::vector<WlcExpansion> adapted_orders = {WlcExpansion::full};
  std::vector<double> adapted_size_ratios = {2.0};
  int adapted_seeds = 4;  ///< in [1, 64]
  /// Continuum rows on the refined mesh (Method::refined: the icosphere refined towards the
  /// scene by red-green refinement, keeping its mirrors; exact contact load, quadric-fit
  /// diameters): requested element counts (empty = none), each run with every law of
  /// refined_orders and every size ratio of refined_size_ratios. Swept as the uniform
  /// meshes are: the default orientation once per solver path of `symmetries`, and the
  /// rotations spread_seeds (the coarse icosphere turned) in full; a row's errors are the
  /// worst over them. Their rows are written beside the table's (accuracy_cost_refined.csv),
  /// not into it.
  std::vector<int> refined_elements;
  std::vector<WlcExpansion> refined_orders = {WlcExpansion::full};
  std::vector<double> refined_size_ratios = {2.0, 3.0};
  /// Continuum rows on the Loop element (Method::loop: the C1 subdivision element on the uniform
  /// icosphere with its vertices on the Evans-Fung surface; the load and the diameters on the
  /// limit surface): requested element counts (empty = none), each run with every law of
  /// loop_orders. Swept as the uniform meshes are: the default orientation once per solver path
  /// of `symmetries`, the rotations spread_seeds in full; a row's errors are the worst over
  /// them. Their rows are written beside the table's (accuracy_cost_loop.csv, size ratio 1),
  /// not into it.
  std::vector<int> loop_elements;
  std::vector<WlcExpansion> loop_orders = {WlcExpansion::full};
  /// The reference: the discrete model at the full spectrin level (N ~ 27,500, i.e. the
  /// icosphere with 27,042 vertices) on each of these triangulation rotations
  /// (RestShapeOptions::rotation_seed; 0 = the default orientation).
  int reference_vertices = 27500;
  std::vector<unsigned> reference_seeds = {0, 1, 2, 3, 4};
  /// The reference sweeps' force tolerance (pN per vertex), far tighter than the methods'
  /// default 1e-3 pN: at the full spectrin level a global mode is so soft that a per-vertex
  /// force tolerance pins D_T loosely. Against 1e-6 pN (seed 0, 13 forces): 1e-3
  /// pN errs by up to 3.2e-3 relative (D_T at 130 pN), 1e-4 pN by 4.1e-4, 1e-5 pN by 1.3e-4,
  /// ten times below the rotations' spread (1.5e-3); the table ranks differences down to
  /// ~1e-3. 1e-6 pN itself is out of reach on some rotations (seed 1 stalls at 5e-6 pN at
  /// 0 pN: the line search's energy differences reach rounding). A 13-force sweep at 1e-5 pN
  /// takes ~25 s. The table's entries keep the default tolerance: the methods as run.
  double reference_force_tolerance_pN = 1e-5;
  /// Extra rotations of every table size up to spread_max_resolution (vertices or elements):
  /// how much a result at that size depends on where its triangulation lies.
  std::vector<unsigned> spread_seeds = {1, 2, 3};
  int spread_max_resolution = 8000;
  /// Solver paths of the table: each default-triangulation sweep (the table sizes and the
  /// reference's seed 0) is run once per entry, so every method appears at its best. A
  /// mirror row shares its mesh with the full row, so its errors, measured from its own sweep,
  /// equal the full row's to the solver tolerance unless the symmetric state is missed; its
  /// cost is its own. Must include none (the convergence study reads the full sweeps).
  /// Rotated triangulations share no mirror with the bead load, so they are swept once, in
  /// full, and the reference is built from full sweeps.
  std::vector<Symmetry> symmetries = {Symmetry::none, Symmetry::mirror};
  /// Cost unit: one energy+gradient evaluation of the discrete network with this many
  /// vertices (the same for every method, so costs compare across methods).
  int cost_unit_vertices = 1000;
  /// Directory of per-run CSV files: a run found there is read, not repeated ("" = none).
  std::string cache_dir;
  void validate() const;  ///< throws std::invalid_argument naming the field
};

/// One stretch sweep (one method, one triangulation) with its cost: the run (its
/// eval_cpu_s measured) and the CPU time of one cost-unit evaluation in the same process.
struct StudyRun {
  MethodRun run;
  double unit_eval_cpu_s = 0;
  /// A reference sweep (at AccuracyStudyOptions::reference_force_tolerance_pN; not a table
  /// entry), or a table sweep at the default tolerance.
  bool reference = false;
};

/// Reference diameters per force: mean and sample standard deviation over triangulations.
struct ReferencePoint {
  double force_pN = 0;
  double axial_um = 0, axial_sd_um = 0, transverse_um = 0, transverse_sd_um = 0;
  int samples = 0;
};

/// Richardson extrapolation of a nested chain h, h/2, h/4 (three values v1, v2, v3):
/// observed order p = log2((v1 - v2)/(v2 - v3)); limit v3 + (v3 - v2)/(2^p - 1).
/// `clean` when the differences share their sign and 0.5 <= p <= 4.
struct Richardson {
  double limit = 0, order = 0;
  bool clean = false;
};
Richardson richardson_chain(double v1, double v2, double v3);

/// Observed order p of error ~ h^p with h ~ N^(-1/2) (N vertices): the least-squares slope
/// of log(error) against log(h) over the points. Returns 0 for fewer than two points.
double observed_order(const std::vector<double>& vertices, const std::vector<double>& errors);

/// One row of the trade-off table: a method at one resolution. Its errors are the worst
/// over the triangulation rotations run at that size (the default one included), so a
/// ranking does not rest on a lucky orientation; error_default is the default mesh's alone
/// (what `rbc stretch` computes).
struct AccuracyRow {
  Method method;
  Symmetry symmetry = Symmetry::none;  ///< solver path of the cost (the errors do not depend on it)
  int vertices = 0, elements = 0;
  bool converged = false;  ///< every rotation converged at every force
  int rotations = 0;       ///< triangulations behind the errors
  /// Largest relative error of D_A and D_T against the reference, per force.
  std::vector<double> error_by_force;
  double error_all = 0, error_low = 0, error_mid = 0, error_high = 0;  ///< max over ranges
  double error_default = 0;  ///< the default triangulation's, max over all forces
  double cost_eg = 0;        ///< CPU of the 13-force sweep / CPU of the cost-unit evaluation
  double own_eg = 0;         ///< the same in evaluations of its own model (as `rbc bench`)
  double cpu_s = 0, wall_s = 0;
  double spread = 0;  ///< largest relative sd of D_A, D_T over rotations (0 if not run)
};

/// Force ranges of the per-range errors (pN): low < 50 <= mid < 120 <= high.
inline constexpr double kLowForceLimit_pN = 50.0, kHighForceLimit_pN = 120.0;

/// Richardson extrapolation of one nested continuum chain at one force.
struct ChainExtrapolation {
  WlcExpansion order = WlcExpansion::order2;
  int elements[3] = {0, 0, 0};  ///< requested element counts, h, h/2, h/4
  double force_pN = 0;
  Richardson axial, transverse;
};

/// Richardson extrapolation of three values on meshes refined by the factor `h_ratio` (> 1)
/// in h each: observed order p = log((v1 - v2)/(v2 - v3)) / log(h_ratio); limit
/// v3 + (v3 - v2)/(h_ratio^p - 1); clean as richardson_chain.
Richardson richardson_chain(double v1, double v2, double v3, double h_ratio);

/// Richardson extrapolation of one adapted-mesh chain (elements e, 2e, 4e: h ratio sqrt 2)
/// on one mesh seed at one force.
struct AdaptedChainExtrapolation {
  WlcExpansion order = WlcExpansion::full;
  double size_ratio = 2.0;
  unsigned seed = 0;
  int elements[3] = {0, 0, 0};
  double force_pN = 0;
  Richardson axial, transverse;
};

struct AccuracyStudy {
  AccuracyStudyOptions options;
  std::vector<StudyRun> runs;
  std::vector<ReferencePoint> reference;
  double reference_relative_sd = 0;  ///< largest sd/mean of the reference over forces
  /// Relative standard error of the reference mean (reference_relative_sd / sqrt(samples)).
  double reference_relative_se = 0;
  std::vector<AccuracyRow> rows;
  std::vector<ChainExtrapolation> chains;
  /// Chains of the adapted rows (AccuracyStudyOptions::adapted_elements with e, 2e and 4e).
  std::vector<AdaptedChainExtrapolation> adapted_chains;
};

/// Runs (or reads from the cache, re-checked before each sweep, so several processes can
/// share one cache) every sweep the options list: the table sizes with their rotations,
/// then the reference triangulations.
std::vector<StudyRun> run_accuracy_sweeps(const AccuracyStudyOptions& options,
                                          const ProgressSink& progress);

/// Runs (or reads from the cache) every sweep and builds the table.
AccuracyStudy run_accuracy_study(const AccuracyStudyOptions& options, const ProgressSink& progress);

/// The table part alone, from finished runs (the reference is the mean of the runs marked
/// StudyRun::reference, discrete at options.reference_vertices, full path; rows are the
/// other seed-0 runs, with the other rotations of their size).
AccuracyStudy assemble_accuracy_study(const AccuracyStudyOptions& options,
                                      std::vector<StudyRun> runs);

/// Writes DIR/accuracy_cost.csv (one row per method), accuracy_by_force.csv (the per-force
/// errors `rbc stretch --accuracy` reads), reference.csv, convergence.csv (every run's
/// diameters, for the observed orders) and the PNGs accuracy_cost.png, convergence_*.png.
/// Rows and sweeps of the adapted mesh go to their own files only, when there are any:
/// accuracy_cost_adapted.csv and accuracy_by_force_adapted.csv (the columns of the table's
/// files and size_ratio), convergence_adapted.csv, orders_adapted.csv and
/// richardson_adapted.csv. Rows and sweeps of the refined mesh likewise go to
/// accuracy_cost_refined.csv, accuracy_by_force_refined.csv, convergence_refined.csv (the full
/// sweeps) and orders_refined.csv (the full path's rows); the Loop element's to the *_loop files
/// in the same way.
void write_accuracy_study(const AccuracyStudy& study, const std::string& dir);

/// Cost ratios below this count as a tie in the verdicts: CPU-time costs of the same sweep
/// repeated in another process on the shared machine came out 0.82-1.08 x the first.
inline constexpr double kAccuracyCostTieRatio = 1.25;

/// accuracy_cost.csv read back (error_by_force left empty); throws std::runtime_error
/// naming the file if it is missing or malformed.
struct AccuracyCostTable {
  std::vector<AccuracyRow> rows;
  double reference_relative_sd = 0;
  int cost_unit_vertices = 0;
};
/// Which rows a cost file holds: the table's (accuracy_cost.csv) or those beside it
/// (accuracy_cost_adapted.csv, accuracy_cost_refined.csv, accuracy_cost_loop.csv: the same
/// columns and size_ratio; their methods get Method::adapted, refined or loop and the size
/// ratio).
enum class CostRows { table, adapted, refined, loop };
AccuracyCostTable load_accuracy_cost(const std::string& path, CostRows rows = CostRows::table);

/// The plain-language answer to "is the continuum model cheaper at equal accuracy?" per
/// force range and accuracy level (0.5, 1, 2, 5 %), from the rows: for each, the cheapest
/// converged entry of each model meeting it and the cost ratio. Markdown bullet lines.
std::string accuracy_verdict(const std::vector<AccuracyRow>& rows, double reference_relative_sd,
                             int cost_unit_vertices);
std::string accuracy_study_verdict(const AccuracyStudy& study);

}  // namespace rbc
