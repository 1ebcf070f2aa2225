#pragma once
// Hessian of one hinge's integrated mean curvature q_e = L_e theta_e (Juelicher 1996), the
// building block of discrete/bending_energy.hpp's juelicher_bending_energy. Value and
// gradient are those of discrete/ hinge_length_angle; the Hessian is new and is obtained by
// forward-mode automatic differentiation (Eigen AutoDiff, 12 directions) of that same
// analytic gradient, so it is exact to rounding.
#include <Eigen/Core>

#include "core/geometry.hpp"

namespace rbc {

using Matrix12d = Eigen::Matrix<double, 12, 12>;

/// q = |b - a| theta(a, b, c, d) (um) for the hinge (a, b) with opposite vertices c (in the
/// face traversing a -> b) and d; theta is core/geometry.hpp's exterior dihedral angle.
/// Writes the gradient (3 x 4 columns a, b, c, d; dimensionless) and the Hessian
/// (12 x 12, vertex-major a, b, c, d; 1/um) when requested.
double hinge_length_angle_hessian(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                  Eigen::Matrix<double, 3, 4>* grad, Matrix12d* hess);

}  // namespace rbc
