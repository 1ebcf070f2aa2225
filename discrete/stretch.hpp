#pragma once
// Zero-temperature optical-tweezers stretch of the discrete network: for each force, the
// free energy is minimised (L-BFGS) from the previous equilibrium (continuation in force),
// with area and volume held by augmented-Lagrangian outer updates.
#include <vector>

#include "core/lbfgs.hpp"
#include "core/progress.hpp"
#include "discrete/network.hpp"

namespace rbc {

struct StretchOptions {
  LbfgsOptions minimiser;       ///< force_tolerance in pN per vertex
  int max_outer_iterations = 40;  ///< augmented-Lagrangian multiplier updates per force
  /// Precondition L-BFGS with a sparse Cholesky factorisation (CHOLMOD) of
  /// approximate_hessian() (+ the area/volume penalties by Woodbury), rebuilt at the start
  /// of every force, for networks with at least this many vertices. It cuts iterations
  /// ~10x at large N; below it, plain L-BFGS is cheaper. 0 = always, INT_MAX = never.
  int precondition_min_vertices = 1500;
  StretchOptions() {
    minimiser.force_tolerance = 1e-3;
    minimiser.max_iterations = 50000;
  }
};

/// One equilibrium of the stretch.
struct StretchPoint {
  double force_pN = 0;
  double axial_um = 0, transverse_um = 0;
  double energy_pNum = 0;       ///< free energy without the constraint terms
  int iterations = 0;           ///< L-BFGS iterations summed over outer updates
  bool converged = false;
  double residual_pN = 0;       ///< largest net vertex force at the end
  double area_drift = 0, volume_drift = 0;  ///< relative (A - A0)/A0, (V - V0)/V0
  double wall_s = 0;
  int vertices = 0;
  std::string status;           ///< minimiser status in words
  Positions x;                  ///< equilibrium positions (um)
};

/// Solves one force from x (updated in place) carrying the multipliers along.
StretchPoint solve_equilibrium(const Network& net, double force_pN, Positions& x,
                               ConstraintMultipliers& lambda, const StretchOptions& options,
                               const ProgressSink& progress = {});

/// Continuation over the forces (in the given order) from the rest shape.
std::vector<StretchPoint> run_stretch(const Network& net, const std::vector<double>& forces_pN,
                                      const StretchOptions& options,
                                      const ProgressSink& progress = {});

}  // namespace rbc
