// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Total area and enclosed volume held by an augmented Lagrangian (MODEL.md section 2,
// "Area and volume"): the lipid bilayer is near-inextensible and the cytosol incompressible.
#include "core/mesh.hpp"

namespace rbc {

/// Penalty stiffnesses of the augmented Lagrangian. With multipliers updated to
/// convergence the constraints hold exactly; with multipliers fixed at 0 this is Model 1's
/// plain penalty k/2 (G - G0)^2 (note: k/2 here, the paper writes k).
struct ConstraintParameters {
  double area_stiffness_pN_per_um3 = 100.0;
  double volume_stiffness_pN_per_um5 = 100.0;
  double tolerance = 1e-6;  ///< relative drift |G - G0|/G0 at which the outer loop stops
  /// Stiffnesses finite and > 0, tolerance finite in (0, 1) (rbc::InvalidParameter).
  void validate() const;
};

/// Multipliers: lambda_A is a tension (pN/um), lambda_V a pressure (pN/um^2).
struct ConstraintMultipliers {
  double area_pN_per_um = 0.0;
  double volume_pN_per_um2 = 0.0;
};

struct ConstraintState {
  double area_um2 = 0, volume_um3 = 0;
};

/// The constraint energy from the totals alone (A in um^2, V in um^3):
/// E = lA (A - A0) + kA/2 (A - A0)^2 + lV (V - V0) + kV/2 (V - V0)^2   [pN um].
double constraint_energy_of_totals(double area_um2, double volume_um3, double area0_um2,
                                   double volume0_um3, const ConstraintParameters& params,
                                   const ConstraintMultipliers& lambda);

/// E = lA (A - A0) + kA/2 (A - A0)^2 + lV (V - V0) + kV/2 (V - V0)^2   [pN um]
/// with A = sum_f A_f, V = sum_f x_a.(x_b x x_c)/6. Gradient accumulated into grad.
double constraint_energy(const Positions& x, const Topology& topo, double area0_um2,
                         double volume0_um3, const ConstraintParameters& params,
                         const ConstraintMultipliers& lambda, Positions* grad = nullptr,
                         ConstraintState* state = nullptr);

struct NetworkGeometry;    // discrete/network_energy.hpp
struct GeometricGradient;  // discrete/network_energy.hpp
/// The same energy from the shared geometry's totals; adds the tension
/// dE/dA = lA + kA (A - A0) to every face-area coefficient of grad and the pressure
/// dE/dV = lV + kV (V - V0) to its volume coefficient when grad != nullptr.
double constraint_energy(const NetworkGeometry& geo, double area0_um2, double volume0_um3,
                         const ConstraintParameters& params, const ConstraintMultipliers& lambda,
                         GeometricGradient* grad);

}  // namespace rbc
