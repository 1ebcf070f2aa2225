// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/constraint_energy.hpp"

#include <stdexcept>
#include <string>

#include "core/geometry.hpp"
#include "core/parallel.hpp"
#include "core/validation.hpp"
#include "discrete/network_energy.hpp"

namespace rbc {

void ConstraintParameters::validate() const {
  require_finite_in_range("area penalty stiffness", "pN/um^3", area_stiffness_pN_per_um3, 0.0,
                          kUnbounded);
  require_finite_in_range("volume penalty stiffness", "pN/um^5", volume_stiffness_pN_per_um5, 0.0,
                          kUnbounded);
  require_finite_in_range("relative area/volume tolerance", "", tolerance, 0.0, 1.0,
                          Ends::open_open);
}

double constraint_energy_of_totals(double area, double volume, double area0, double volume0,
                                   const ConstraintParameters& p,
                                   const ConstraintMultipliers& lambda) {
  const double da = area - area0, dv = volume - volume0;
  return lambda.area_pN_per_um * da + 0.5 * p.area_stiffness_pN_per_um3 * da * da +
         lambda.volume_pN_per_um2 * dv + 0.5 * p.volume_stiffness_pN_per_um5 * dv * dv;
}

namespace {

/// dE/dA (pN/um) and dE/dV (pN/um^2) of constraint_energy_of_totals.
struct ConstraintForces {
  double tension = 0, pressure = 0;
};
ConstraintForces constraint_forces(double area, double volume, double area0, double volume0,
                                   const ConstraintParameters& p,
                                   const ConstraintMultipliers& lambda) {
  return {lambda.area_pN_per_um + p.area_stiffness_pN_per_um3 * (area - area0),
          lambda.volume_pN_per_um2 + p.volume_stiffness_pN_per_um5 * (volume - volume0)};
}

}  // namespace

double constraint_energy(const NetworkGeometry& geo, double area0, double volume0,
                         const ConstraintParameters& p, const ConstraintMultipliers& lambda,
                         GeometricGradient* grad) {
  if (grad) {
    const ConstraintForces cf =
        constraint_forces(geo.area_um2, geo.volume_um3, area0, volume0, p, lambda);
    grad->area += cf.tension;
    grad->volume += cf.pressure;
  }
  return constraint_energy_of_totals(geo.area_um2, geo.volume_um3, area0, volume0, p, lambda);
}

double constraint_energy(const Positions& x, const Topology& topo, double area0, double volume0,
                         const ConstraintParameters& p, const ConstraintMultipliers& lambda,
                         Positions* grad, ConstraintState* state) {
  const double area = total_area(x, topo), volume = enclosed_volume(x, topo);
  if (state) *state = {area, volume};
  const ConstraintForces cf = constraint_forces(area, volume, area0, volume0, p, lambda);
  const double tension = cf.tension, pressure = cf.pressure;
  if (grad) {
    assemble_parallel(topo.num_faces(), grad, [&](int f, Positions& g) {
      const auto& t = topo.faces.col(f);
      Eigen::Matrix3d ga, gv;
      triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)), &ga);
      tetra_volume(x.col(t(0)), x.col(t(1)), x.col(t(2)), &gv);
      for (int k = 0; k < 3; ++k) g.col(t(k)) += tension * ga.col(k) + pressure * gv.col(k);
      return 0.0;
    });
  }
  return constraint_energy_of_totals(area, volume, area0, volume0, p, lambda);
}

}  // namespace rbc
