// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The models the comparison runs, behind one call: a method (model + resolution + law)
// stretched over a list of forces returns a curve of diameters with its cost.
#include <functional>
#include <string>
#include <vector>

#include "core/cpu_time.hpp"         // process_cpu_seconds, used with these timings
#include "core/mirror_symmetry.hpp"  // Symmetry
#include "core/progress.hpp"
#include "discrete/network.hpp"
#include "discrete/wlc.hpp"

namespace rbc {

enum class MethodKind { discrete, continuum };

struct Method {
  MethodKind kind = MethodKind::discrete;
  int resolution = 2000;                      ///< vertices (discrete) or elements (continuum)
  WlcExpansion order = WlcExpansion::order2;  ///< continuum law (discrete: always the full WLC)
  /// Triangulation orientation (RestShapeOptions::rotation_seed; 0 = the default mesh). On
  /// the adapted mesh: the mesher's seed (AdaptedMeshOptions::seed), its analogue.
  unsigned rotation_seed = 0;
  /// Continuum only: the mesh graded to the stretch scene (continuum/adapted_mesh.hpp, about
  /// `resolution` triangles, coarse / fine edge length `size_ratio`) instead of the uniform
  /// icosphere, run with the exact contact load and the quadric-fit diameters
  /// (ContinuumLoad::exact_contact, ContinuumMeasure::quadric_fit), as
  /// `rbc stretch --mesh adapted --contact-load exact-contact --measure quadric-fit`.
  bool adapted = false;
  /// Continuum only: the icosphere refined towards the scene by red-green refinement
  /// (continuum/refined_mesh.hpp, about `resolution` triangles, coarse / fine edge length
  /// `size_ratio`; rotation_seed turns the coarse icosphere), its vertices on the Evans-Fung
  /// surface (RefinedMeshOptions' default), run with the exact contact load and the quadric-fit
  /// diameters, as `rbc stretch --mesh refined --contact-load exact-contact --measure
  /// quadric-fit`. It keeps the icosphere's mirrors (seed 0).
  bool refined = false;
  /// Continuum only: the C1 Loop element (continuum/loop_stretch.hpp) on the uniform icosphere
  /// of `resolution` triangles (rotation_seed turns it) with its vertices on the Evans-Fung
  /// surface: every term on the smooth limit surface, the bead load on the caps of the rest
  /// limit surface, the diameters measured on the limit surface, as
  /// `rbc stretch --element loop`. It keeps the icosphere's mirrors (seed 0).
  bool loop = false;
  /// adapted or refined only: AdaptedMeshOptions::size_ratio or RefinedMeshOptions::size_ratio,
  /// in [1, 10]
  double size_ratio = 2.0;
  /// Short stable name, e.g. "discrete_N2000", "continuum_p2_E4000",
  /// "continuum_adapted2_pfull_E2000", "continuum_refined3_pfull_E1700" or
  /// "continuum_loop_pfull_E980" (+ "_r3" if rotated or seeded 3).
  std::string name() const;
  /// Legend label, e.g. "microscopic model (N = 2000)".
  std::string label() const;
};

/// Parses "discrete:N", "continuum:ORDER:ELEMENTS" (ORDER 2, 3, 4 or full) or
/// "continuum-adapted:ORDER:ELEMENTS[:RATIO]" (the adapted mesh, size ratio RATIO in [1, 10],
/// default 2), "continuum-refined:ORDER:ELEMENTS[:RATIO]" (the refined mesh, the same) or
/// "continuum-loop:ORDER:ELEMENTS" (the Loop element).
/// Throws std::invalid_argument naming the text.
Method parse_method(const std::string& text);

struct CurvePoint {
  double force_pN = 0, axial_um = 0, transverse_um = 0;
  double wall_s = 0, residual = 0;
  int iterations = 0;
  bool converged = false;
};

struct MethodRun {
  Method method;
  /// The solver path the run took (RunMethodOptions::symmetry): the same discretisation
  /// either way, so the diameters agree to the solver tolerance; only the cost differs.
  Symmetry symmetry = Symmetry::none;
  int vertices = 0, elements = 0;
  std::vector<CurvePoint> points;
  double setup_s = 0;  ///< mesh generation and set-up
  double total_s = 0;  ///< set-up plus all forces
  double cpu_s = 0;    ///< process CPU time of all forces (s), set-up excluded
  /// CPU time (s) of one energy+gradient evaluation of this model at its rest shape
  /// (RunMethodOptions::measure_evaluation; 0 otherwise).
  double eval_cpu_s = 0;
  double patch_plus_um2 = 0, patch_minus_um2 = 0;  ///< bead contact patches at rest
  double surface_um2 = 0;                          ///< rest surface area
  bool all_converged() const;
};

struct RunMethodOptions {
  bool measure_evaluation = false;  ///< also time one energy+gradient evaluation (CPU)
  /// Symmetry::mirror: solve on the mirror-symmetric states, each checked for stability
  /// (StretchOptions::symmetry, NewtonOptions::symmetry); the mesh is unchanged.
  Symmetry symmetry = Symmetry::none;
  /// Discrete methods: the minimiser's force tolerance (pN per vertex); 0 = StretchOptions'
  /// default (1e-3 pN).
  double discrete_force_tolerance_pN = 0;
  /// The physics both models share (WLC, steric, bending, bead contact; default: paper Tables
  /// 1-2): the discrete model's network and the continuum model's law, bending and contact.
  NetworkParameters parameters;
};

/// CPU time (s) of one call of `eval`: the median of 7 batches of at least 20 ms CPU each.
double evaluation_cpu_seconds(const std::function<void()>& eval);
/// CPU time (s) of one energy+gradient evaluation of `net` at its rest shape (88 pN load).
double network_evaluation_cpu_seconds(const Network& net);

/// The discrete network every comparison uses at a resolution: the Evans-Fung rest shape
/// triangulated with about `vertices` vertices and the default spectrin parameters.
Network make_discrete_network(int vertices);
/// The same on the triangulation turned by `rotation_seed` (0: identical to the above).
Network make_discrete_network(int vertices, unsigned rotation_seed);
/// The same with the given physics.
Network make_discrete_network(int vertices, unsigned rotation_seed,
                              const NetworkParameters& parameters);

/// Stretches the cell with the method over `forces_pN` (continuation in the given order).
MethodRun run_method(const Method& method, const std::vector<double>& forces_pN,
                     const ProgressSink& progress);
MethodRun run_method(const Method& method, const std::vector<double>& forces_pN,
                     const ProgressSink& progress, const RunMethodOptions& options);

}  // namespace rbc
