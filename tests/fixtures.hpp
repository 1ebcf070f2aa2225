// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Shared test fixtures: seeded random perturbations and small meshes.
#include <omp.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <random>

#include "core/mesh.hpp"
#include "core/rest_shape.hpp"

namespace rbc::testing {

/// Runs its scope on one OpenMP thread: the parallel reductions (rest shape, network energy,
/// hence L-BFGS) sum in thread-arrival order, so only then are results bit-reproducible.
struct OneOpenMpThread {
  int saved = omp_get_max_threads();
  OneOpenMpThread() { omp_set_num_threads(1); }
  ~OneOpenMpThread() { omp_set_num_threads(saved); }
  OneOpenMpThread(const OneOpenMpThread&) = delete;
  OneOpenMpThread& operator=(const OneOpenMpThread&) = delete;
};

/// A seeded uniformly random rotation (a normalised Gaussian quaternion).
inline Eigen::Matrix3d random_rotation(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized().toRotationMatrix();
}

/// Positions of an icosphere of the given frequency scaled to radius r (um).
inline TriMesh sphere_mesh(int frequency, double radius_um) {
  TriMesh m = make_icosphere(frequency);
  m.x *= radius_um;
  return m;
}

/// Adds a seeded uniform perturbation of relative size `amplitude` x mean edge length,
/// so finite-difference tests never sit on a symmetric point where gradients vanish.
inline void perturb(Positions& x, double amplitude_um, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += amplitude_um * u(rng);
}

/// Central-difference check of a gradient: returns the largest absolute error over
/// `samples` random coordinates for step h. Truncation error is O(h^2).
inline double fd_gradient_error(const std::function<double(const Eigen::VectorXd&)>& f,
                                const Eigen::VectorXd& x, const Eigen::VectorXd& grad, double h,
                                int samples, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<Eigen::Index> pick(0, x.size() - 1);
  double worst = 0.0;
  Eigen::VectorXd xp = x;
  for (int s = 0; s < samples; ++s) {
    const Eigen::Index i = samples >= x.size() ? s % x.size() : pick(rng);
    xp = x;
    xp(i) += h;
    const double fp = f(xp);
    xp(i) -= 2 * h;
    const double fm = f(xp);
    worst = std::max(worst, std::abs((fp - fm) / (2 * h) - grad(i)));
  }
  return worst;
}

/// Directional central difference along a random direction d: (f(x+hd)-f(x-hd))/2h - g.d.
/// Returns the error for steps h and h/2; their ratio should approach 4 (second order).
inline std::pair<double, double> fd_directional_errors(
    const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
    const Eigen::VectorXd& grad, double h, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::VectorXd d(x.size());
  for (Eigen::Index i = 0; i < d.size(); ++i) d(i) = n(rng);
  d /= d.norm();
  auto err = [&](double step) {
    return std::abs((f(x + step * d) - f(x - step * d)) / (2 * step) - grad.dot(d));
  };
  return {err(h), err(h / 2)};
}

}  // namespace rbc::testing
