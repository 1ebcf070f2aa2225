#include "continuum/hinge_hessian.hpp"

#include "discrete/element_hessian.hpp"

namespace rbc {

// One implementation serves both scales: discrete/element_hessian.hpp differentiates the
// analytic hinge gradient by forward-mode AD; the continuum keeps its own name and layout.
double hinge_length_angle_hessian(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                  Eigen::Matrix<double, 3, 4>* grad, Matrix12d* hess) {
  return hinge_length_angle_second(a, b, c, d, grad, hess);
}

}  // namespace rbc
