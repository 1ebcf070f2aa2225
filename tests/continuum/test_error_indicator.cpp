// SPDX-License-Identifier: GPL-3.0-or-later
// The Zienkiewicz-Zhu error indicator (continuum/error_indicator.hpp): the element stress
// tensor against principal_tensions, zero on homogeneous deformations (a flat patch stretched
// and sheared uniformly, a sphere inflated uniformly), O(h) on a smooth non-uniform one, and
// largest at the bead-contact rims of a stretched cell.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <iostream>
#include <random>

#include "continuum/contact_load.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/error_indicator.hpp"
#include "fixtures.hpp"
#include "homogenise/invariant_laws.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace error_indicator_test {
namespace {

/// Size of the stress field for round-off comparisons: sqrt(sum_T A_T |tau_T|^2) (pN).
double stress_norm(const Positions& x, const Faces& faces, const std::vector<Eigen::Matrix3d>& s) {
  double sum = 0;
  for (Eigen::Index f = 0; f < faces.cols(); ++f)
    sum += triangle_area(x.col(faces(0, f)), x.col(faces(1, f)), x.col(faces(2, f))) *
           s[static_cast<size_t>(f)].squaredNorm();
  return std::sqrt(sum);
}

std::vector<Eigen::Matrix3d> stresses(const IsotropicMembraneLaw& law, const Positions& rest,
                                      const Positions& x, const Faces& faces) {
  std::vector<Eigen::Matrix3d> s;
  for (Eigen::Index f = 0; f < faces.cols(); ++f) {
    const MembraneReference ref = make_membrane_reference(
        rest.col(faces(0, f)), rest.col(faces(1, f)), rest.col(faces(2, f)));
    s.push_back(element_stress_tensor(law, ref, x.col(faces(0, f)), x.col(faces(1, f)),
                                      x.col(faces(2, f))));
  }
  return s;
}

TEST(ErrorIndicator, ElementStressTensorHasThePrincipalTensions) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const Vec3 x0(0, 0, 0), x1(1, 0.1, 0.2), x2(0.2, 0.9, -0.1);
  const MembraneReference ref = make_membrane_reference(x0, x1, x2);
  const Vec3 y0(0.1, 0, 0.3), y1(1.3, 0.0, 0.1), y2(0.1, 1.0, 0.2);
  const Eigen::Matrix3d tau = element_stress_tensor(law, ref, y0, y1, y2);
  EXPECT_LT((tau - tau.transpose()).norm(), 1e-12 * tau.norm());
  const Vec3 n = triangle_normal(y0, y1, y2);
  EXPECT_LT((tau * n).norm(), 1e-12 * tau.norm());  // tangent to the current element
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(tau);
  const PrincipalTensions pt = principal_tensions(law, ref, y0, y1, y2);
  // Eigenvalues: 0 (normal) and t1, t2 (tangential), in some order.
  std::vector<double> ev = {es.eigenvalues()(0), es.eigenvalues()(1), es.eigenvalues()(2)};
  std::vector<double> want = {0.0, pt.t1, pt.t2};
  std::sort(ev.begin(), ev.end());
  std::sort(want.begin(), want.end());
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(ev[k], want[k], 1e-10 * std::abs(pt.t1));
}

TEST(ErrorIndicator, VanishesOnAUniformlyDeformedFlatPatch) {
  // A jittered flat grid (open patch) in z = 0, mapped by one affine map: stretch, shear and a
  // rigid turn out of the plane. Every element has the same deformation gradient.
  const int n = 9;
  Positions rest(3, n * n);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> jitter(-0.25, 0.25);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const bool interior = i > 0 && j > 0 && i < n - 1 && j < n - 1;
      rest.col(i * n + j) << (i + (interior ? jitter(rng) : 0.0)) * 0.4,
          (j + (interior ? jitter(rng) : 0.0)) * 0.4, 0.0;
    }
  Faces faces(3, 2 * (n - 1) * (n - 1));
  int f = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = (i + 1) * n + j, c = (i + 1) * n + j + 1, d = i * n + j + 1;
      faces.col(f++) << a, b, c;
      faces.col(f++) << a, c, d;
    }
  Eigen::Matrix3d map;
  map << 1.25, 0.15, 0, 0.05, 0.9, 0, 0, 0, 1;
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Positions x = turn * map * rest;
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const std::vector<Eigen::Matrix3d> s = stresses(law, rest, x, faces);
  const Eigen::VectorXd eta = recovery_error_indicator(x, faces, s);
  EXPECT_LT(eta.maxCoeff(), 1e-13 * stress_norm(x, faces, s));
  // The same patch deformed non-uniformly (a bend of the in-plane map) is flagged.
  Positions y = x;
  for (Eigen::Index v = 0; v < y.cols(); ++v) y(0, v) += 0.05 * rest(1, v) * rest(1, v);
  EXPECT_GT(recovery_error_indicator(y, faces, stresses(law, rest, y, faces)).minCoeff(), 0.0);
}

TEST(ErrorIndicator, VanishesOnAUniformlyInflatedSphere) {
  // x = s X on a sphere: every element is stretched isotropically by s, tau_T = t P_T with the
  // element's own tangent projector; the recovery's rotations carry t P_T into t P_v exactly.
  const TriMesh m = testing::sphere_mesh(6, 3.0);
  const ContinuumModel model = build_continuum_model(m, testing::closed_form_p2_law(), {});
  const Positions x = 1.05 * m.x;
  const Eigen::VectorXd eta = error_indicator(model, x);
  std::vector<Eigen::Matrix3d> s = stresses(model.law, m.x, x, m.topo.faces);
  EXPECT_LT(eta.maxCoeff(), 1e-13 * stress_norm(x, m.topo.faces, s));
  EXPECT_GT(s[0].norm(), 1.0);  // a real stress, not a zero one
}

TEST(ErrorIndicator, FallsAtFirstOrderOnASmoothNonUniformField) {
  // x = D X on a sphere of radius 3 um with D = diag(1.15, 1, 0.95): the surface stretch varies
  // smoothly over the sphere. The element stress is constant per element, so the recovered
  // field differs from it by O(h) and the global indicator sqrt(sum eta_T^2) falls as h.
  std::vector<double> global;
  for (int frequency : {4, 8, 16, 32}) {
    const TriMesh m = testing::sphere_mesh(frequency, 3.0);
    const ContinuumModel model = build_continuum_model(m, testing::closed_form_p2_law(), {});
    const Positions x = Eigen::Vector3d(1.15, 1.0, 0.95).asDiagonal() * m.x;
    const Eigen::VectorXd eta = error_indicator(model, x);
    EXPECT_GT(eta.minCoeff(), 0.0);
    global.push_back(eta.norm());
  }
  for (size_t k = 1; k < global.size(); ++k) {
    const double order = std::log2(global[k - 1] / global[k]);
    std::cout << "sphere, x = diag(1.15, 1, 0.95) X: indicator " << global[k - 1] << " -> "
              << global[k] << " pN, observed order " << order << "\n";
    EXPECT_GT(order, 0.85);
    EXPECT_LT(order, 1.2);
  }
}

TEST(ErrorIndicator, LargestAtTheBeadContactRimsOfAStretchedCell) {
  const TriMesh mesh = make_continuum_mesh(500);
  const ContinuumModel model = build_continuum_model(
      mesh, make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::full), {});
  ContinuumOptions o;
  o.element_fields = false;
  const auto r = run_continuum_stretch(model, {193.0}, o);
  ASSERT_TRUE(r[0].converged);
  const Eigen::VectorXd eta = error_indicator(model, r[0].x);
  // The rims: the rest planes x = +-c of the 5 % contact caps.
  const ContactLoad caps = exact_contact_load(model.rest, model.topo, 0.05);
  const double h = edge_lengths(model.rest, model.topo).mean();
  std::vector<int> order(static_cast<size_t>(eta.size()));
  for (size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return eta(a) > eta(b); });
  auto rim_distance = [&](int f) {
    const auto t = model.topo.faces.col(f);
    const double cx = (model.rest(0, t(0)) + model.rest(0, t(1)) + model.rest(0, t(2))) / 3.0;
    return std::min(std::abs(cx - caps.plane_plus_um), std::abs(cx - caps.plane_minus_um));
  };
  // Elements whose rest centroid lies within half an edge of a rim plane: a band of a few
  // percent of the cell; the ten largest indicators lie in it.
  int band = 0;
  for (int f = 0; f < model.num_elements(); ++f)
    if (rim_distance(f) < 0.5 * h) ++band;
  int near = 0;
  const int top = 10;
  for (int k = 0; k < top; ++k) {
    const int f = order[static_cast<size_t>(k)];
    if (rim_distance(f) < 0.5 * h) ++near;
  }
  const double base_rate = static_cast<double>(band) / model.num_elements();
  std::cout << "  rim band (half an edge): " << base_rate * 100 << " % of the elements; " << near
            << " of the " << top << " largest indicators\n";
  EXPECT_LT(base_rate, 0.15);
  EXPECT_GE(near, 8);
}

}  // namespace
}  // namespace error_indicator_test
}  // namespace rbc
