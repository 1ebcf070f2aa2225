#pragma once
// The models the comparison runs, behind one call: a method (model + resolution + law)
// stretched over a list of forces returns a curve of diameters with its cost.
#include <string>
#include <vector>

#include "core/progress.hpp"
#include "discrete/network.hpp"
#include "discrete/wlc.hpp"

namespace rbc {

enum class MethodKind { discrete, continuum };

struct Method {
  MethodKind kind = MethodKind::discrete;
  int resolution = 2000;                      ///< vertices (discrete) or elements (continuum)
  WlcExpansion order = WlcExpansion::order2;  ///< continuum law (discrete: always the full WLC)
  /// Short stable name, e.g. "discrete_N2000" or "continuum_p2_E4000".
  std::string name() const;
  /// Legend label, e.g. "microscopic model (N = 2000)".
  std::string label() const;
};

/// Parses "discrete:N" or "continuum:ORDER:ELEMENTS" (ORDER 2, 3, 4 or full).
Method parse_method(const std::string& text);

struct CurvePoint {
  double force_pN = 0, axial_um = 0, transverse_um = 0;
  double wall_s = 0, residual = 0;
  int iterations = 0;
  bool converged = false;
};

struct MethodRun {
  Method method;
  int vertices = 0, elements = 0;
  std::vector<CurvePoint> points;
  double setup_s = 0;  ///< mesh generation and set-up
  double total_s = 0;  ///< set-up plus all forces
  bool all_converged() const;
};

/// The discrete network every comparison uses at a resolution: the Evans-Fung rest shape
/// triangulated with about `vertices` vertices and the default spectrin parameters.
Network make_discrete_network(int vertices);

/// Stretches the cell with the method over `forces_pN` (continuation in the given order).
MethodRun run_method(const Method& method, const std::vector<double>& forces_pN,
                     const ProgressSink& progress);

}  // namespace rbc
