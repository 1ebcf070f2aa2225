// SPDX-License-Identifier: GPL-3.0-or-later
// The continuum element kernels: membrane triangle (patch test, derivatives, invariance),
// geometry Hessians, hinge and Juelicher-Helfrich Hessians (STYLE.md 2-3).
#include <gtest/gtest.h>

#include <omp.h>

#include <Eigen/Geometry>
#include <random>

#include "continuum/block_hessian.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/membrane_element.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/element_hessian.hpp"
#include "fixtures.hpp"
#include "hessian_check.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace {

using testing::random_rotation;

// A generic reference triangle and a stretched, sheared, rotated current triangle.
struct TrianglePair {
  Vec3 X[3], x[3];
  TrianglePair() {
    X[0] = {0.1, -0.05, 0.02};
    X[1] = {0.62, 0.03, -0.04};
    X[2] = {0.21, 0.48, 0.07};
    Eigen::Matrix3d F;
    F << 1.25, 0.18, 0.02, -0.07, 0.88, 0.05, 0.11, -0.04, 1.1;
    const Eigen::Matrix3d r = random_rotation(3);
    for (int k = 0; k < 3; ++k) x[k] = r * F * X[k] + Vec3(0.3, -0.2, 0.5);
  }
  Eigen::VectorXd flat_x() const {
    Eigen::VectorXd v(9);
    for (int k = 0; k < 3; ++k) v.segment<3>(3 * k) = x[k];
    return v;
  }
};

TEST(MembraneElement, GradientAndHessianMatchFiniteDifferences) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const TrianglePair t;
  const MembraneReference ref = make_membrane_reference(t.X[0], t.X[1], t.X[2]);
  auto grad_of = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    ElementGradient g;
    membrane_element_energy(law, ref, v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), &g);
    return g;
  };
  auto energy_of = [&](const Eigen::VectorXd& v) {
    return membrane_element_energy(law, ref, v.segment<3>(0), v.segment<3>(3), v.segment<3>(6));
  };
  const Eigen::VectorXd x0 = t.flat_x();
  ElementGradient g;
  ElementHessian h;
  membrane_element_energy(law, ref, t.x[0], t.x[1], t.x[2], &g, &h);
  const auto [e1, e2] = testing::fd_directional_errors(energy_of, x0, g, 1e-2 * 0.5, 4);
  EXPECT_GT(e1 / e2, 3.0);
  EXPECT_LT(testing::fd_gradient_error(energy_of, x0, g, 3e-6, 9, 1), 1e-7 * g.norm());
  EXPECT_LT((h - h.transpose()).norm(), 1e-12 * h.norm());
  for (unsigned s = 0; s < 4; ++s) {
    const auto c = testing::check_hessian_direction(
        grad_of, x0, [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return h * d; }, 0.5, s);
    testing::expect_hessian_ok(c, "membrane element Hessian");
  }
}

TEST(MembraneElement, RigidMotionsCostNothingAndReferenceIsStressFree) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const TrianglePair t;
  const MembraneReference ref = make_membrane_reference(t.X[0], t.X[1], t.X[2]);
  // Rigid image of the reference: energy Abar Psi(0, 0), no force.
  const Eigen::Matrix3d r = random_rotation(17);
  const Vec3 shift(-1.0, 2.0, 0.3);
  ElementGradient g;
  const double e0 = membrane_element_energy(law, ref, r * t.X[0] + shift, r * t.X[1] + shift,
                                            r * t.X[2] + shift, &g);
  EXPECT_NEAR(e0, ref.area_um2 * law.evaluate(0, 0).psi, 1e-12 * std::abs(e0));
  EXPECT_LT(g.norm(), 1e-10 * law.evaluate(0, 0).psi);
  // Rigidly moving a deformed triangle leaves the energy unchanged and rotates the force.
  ElementGradient g1, g2;
  const double a = membrane_element_energy(law, ref, t.x[0], t.x[1], t.x[2], &g1);
  const double b = membrane_element_energy(law, ref, r * t.x[0] + shift, r * t.x[1] + shift,
                                           r * t.x[2] + shift, &g2);
  EXPECT_NEAR(a, b, 1e-12 * std::abs(a));
  for (int k = 0; k < 3; ++k)
    EXPECT_LT((g2.segment<3>(3 * k) - r * g1.segment<3>(3 * k)).norm(), 1e-10 * g1.norm());
  // Translations and infinitesimal rotations are in the Hessian's null space only at a
  // stress-free state: check at the rigid image of the reference.
  ElementHessian h;
  membrane_element_energy(law, ref, t.X[0], t.X[1], t.X[2], nullptr, &h);
  Eigen::VectorXd tr(9), rot(9);
  const Vec3 w(0.3, -0.5, 0.8);
  for (int k = 0; k < 3; ++k) {
    tr.segment<3>(3 * k) = Vec3(0.2, -0.7, 0.4);
    rot.segment<3>(3 * k) = w.cross(t.X[k]);
  }
  EXPECT_LT((h * tr).norm(), 1e-10 * h.norm());
  EXPECT_LT((h * rot).norm(), 1e-10 * h.norm());
}

// Flat periodic-free patch: a perturbed triangulated square, deformed by a uniform
// (3 x 2) surface deformation gradient F, stores exactly Psi(F) x area, and all interior
// vertices are in equilibrium (uniform stress).
TEST(MembraneElement, PatchTestUniformDeformation) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const int n = 6;  // (n+1)^2 vertices, 2 n^2 triangles on the unit square
  std::vector<Eigen::Vector2d> ref;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      Eigen::Vector2d p(double(i) / n, double(j) / n);
      if (i > 0 && i < n && j > 0 && j < n) p += Eigen::Vector2d(u(rng), u(rng)) / n;
      ref.push_back(p);
    }
  std::vector<std::array<int, 3>> tris;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      tris.push_back({a, b, d});
      tris.push_back({a, d, c});
    }
  Eigen::Matrix<double, 3, 2> F;
  F << 1.3, 0.2, -0.1, 0.85, 0.15, 0.05;  // stretch + shear, embedded out of plane
  const Eigen::Matrix3d r = random_rotation(8);
  F = r * F;
  const Eigen::Matrix2d C = F.transpose() * F;
  const double i1 = std::sqrt(C.determinant()) - 1, i2 = C.trace() - 2;
  const double psi = law.evaluate(i1, i2).psi;
  double energy = 0, area = 0;
  const int nv = static_cast<int>(ref.size());
  Eigen::Matrix3Xd grad = Eigen::Matrix3Xd::Zero(3, nv);
  for (const auto& t : tris) {
    Vec3 X[3], x[3];
    for (int k = 0; k < 3; ++k) {
      X[k] = Vec3(ref[t[k]].x(), ref[t[k]].y(), 0.0);
      x[k] = F * ref[t[k]] + Vec3(0.4, 0.1, -0.2);
    }
    const MembraneReference mr = make_membrane_reference(X[0], X[1], X[2]);
    ElementGradient g;
    energy += membrane_element_energy(law, mr, x[0], x[1], x[2], &g);
    for (int k = 0; k < 3; ++k) grad.col(t[k]) += g.segment<3>(3 * k);
    area += mr.area_um2;
  }
  EXPECT_NEAR(area, 1.0, 1e-14);
  EXPECT_NEAR(energy, psi * area, 1e-13 * std::abs(psi));
  double boundary_force = 0;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const int v = j * (n + 1) + i;
      if (i > 0 && i < n && j > 0 && j < n)
        EXPECT_LT(grad.col(v).norm(), 1e-12 * std::abs(psi)) << "interior vertex " << v;
      else
        boundary_force = std::max(boundary_force, grad.col(v).norm());
    }
  EXPECT_GT(boundary_force, 1e-3 * std::abs(psi));  // the patch is loaded, not trivially
}

TEST(MembraneElement, CollapsedElementIsInfeasibleNotNaN) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const TrianglePair t;
  const MembraneReference ref = make_membrane_reference(t.X[0], t.X[1], t.X[2]);
  const Vec3 mid = 0.5 * (t.X[0] + t.X[1]);
  EXPECT_TRUE(std::isinf(membrane_element_energy(law, ref, t.X[0], t.X[1], mid)));
  EXPECT_THROW(make_membrane_reference(t.X[0], t.X[1], mid), std::invalid_argument);
}

TEST(MembraneElement, PrincipalTensionsMatchLinearElasticity) {
  // Small equibiaxial stretch (1 + s): both tensions = 2 K s to first order, K the area
  // modulus from the law's derivatives; tension vanishes at rest.
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const InvariantDerivatives d = law.evaluate(0, 0);
  const double k = 0.5 * d.d1 + d.d2 + d.d11 + 4 * d.d12 + 4 * d.d22;
  const TrianglePair t;
  const MembraneReference ref = make_membrane_reference(t.X[0], t.X[1], t.X[2]);
  const double s = 1e-5;
  const PrincipalTensions p0 = principal_tensions(law, ref, t.X[0], t.X[1], t.X[2]);
  EXPECT_NEAR(p0.t1, 0.0, 1e-9);
  const PrincipalTensions p =
      principal_tensions(law, ref, (1 + s) * t.X[0], (1 + s) * t.X[1], (1 + s) * t.X[2]);
  EXPECT_NEAR(p.t1 / s, 2 * k, 1e-3 * k);
  EXPECT_NEAR(p.t2 / s, 2 * k, 1e-3 * k);
}

TEST(GeometryHessian, AreaAndVolumeMatchFiniteDifferences) {
  const TrianglePair t;
  const Eigen::VectorXd x0 = t.flat_x();
  auto area_grad = [](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    Vector9d g;
    triangle_area_hessian(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), &g, nullptr);
    return g;
  };
  Vector9d g;
  Matrix9d h;
  const double a = triangle_area_hessian(t.x[0], t.x[1], t.x[2], &g, &h);
  EXPECT_NEAR(a, triangle_area(t.x[0], t.x[1], t.x[2]), 1e-14);
  Eigen::Matrix3d gc;
  triangle_area(t.x[0], t.x[1], t.x[2], &gc);
  for (int k = 0; k < 3; ++k) EXPECT_LT((g.segment<3>(3 * k) - gc.col(k)).norm(), 1e-14);
  auto vol_grad = [](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    Eigen::Matrix3d gv;
    tetra_volume(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), &gv);
    return Eigen::Map<Eigen::VectorXd>(gv.data(), 9);
  };
  const Matrix9d hv = tetra_volume_hessian(t.x[0], t.x[1], t.x[2]);
  for (unsigned s = 0; s < 3; ++s) {
    testing::expect_hessian_ok(
        testing::check_hessian_direction(
            area_grad, x0, [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return h * d; }, 0.5,
            s),
        "triangle area");
    // V is cubic: its gradient is quadratic, so the central difference is exact up to
    // round-off (no truncation error to decay).
    const auto c = testing::check_hessian_direction(
        vol_grad, x0, [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return hv * d; }, 0.5, s);
    EXPECT_LT(c.error_h, 1e-12);
  }
}

TEST(HingeHessian, MatchesFiniteDifferencesOfTheAnalyticGradient) {
  const Vec3 a(0.0, 0.0, 0.0), b(0.9, 0.1, 0.05), c(0.4, 0.7, 0.2), d(0.5, -0.6, 0.35);
  Eigen::VectorXd x0(12);
  x0 << a, b, c, d;
  auto grad_of = [](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    Eigen::Matrix<double, 3, 4> g;
    hinge_length_angle_hessian(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9),
                               &g, nullptr);
    return Eigen::Map<Eigen::VectorXd>(g.data(), 12);
  };
  Eigen::Matrix<double, 3, 4> g;
  Matrix12d h;
  const double q = hinge_length_angle_hessian(a, b, c, d, &g, &h);
  EXPECT_NEAR(q, (b - a).norm() * dihedral_angle(a, b, c, d), 1e-14);
  for (unsigned s = 0; s < 4; ++s)
    testing::expect_hessian_ok(
        testing::check_hessian_direction(
            grad_of, x0, [&](const Eigen::VectorXd& dd) -> Eigen::VectorXd { return h * dd; }, 0.8,
            s),
        "hinge L theta");
  // q is invariant under rigid motions: translations are in the null space of the Hessian.
  Eigen::VectorXd tr(12);
  for (int k = 0; k < 4; ++k) tr.segment<3>(3 * k) = Vec3(0.3, 0.1, -0.4);
  EXPECT_LT((h * tr).norm(), 1e-12 * h.norm());
}

// The closed form against the automatic-differentiation reference on random hinges: folded
// both ways, nearly flat (theta ~ 0, where atan2 is least forgiving), sharp, and with an
// apex far outside the edge (t_c, t_d outside [0, 1]). Both are exact up to rounding, so they
// agree to a few ulps of the largest entry; a wrong term would show at O(1) relative.
TEST(HingeHessian, ClosedFormMatchesAutomaticDifferentiation) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto rnd = [&] { return Vec3(u(rng), u(rng), u(rng)); };
  int checked = 0;
  double largest_theta = 0.0, smallest_theta = 10.0;
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 a = rnd(), b = a + Vec3(0.8, 0.1, -0.2) + 0.3 * rnd();
    const Vec3 mid = 0.5 * (a + b);
    const Vec3 n = (b - a).cross(Vec3(0.1, 0.9, 0.3)).normalized();
    const Vec3 s = (b - a).cross(n).normalized();  // in-plane, perpendicular to the edge
    // c on one side, d on the other, folded out of plane by a random amount (flat at fold 0).
    const double fold = trial % 4 == 0 ? 1e-6 * u(rng) : 1.2 * u(rng);
    const double along = trial % 5 == 0 ? 2.5 : 0.4;  // apex beyond the edge's ends
    const Vec3 c = mid + along * u(rng) * (b - a) + 0.6 * s + fold * n;
    const Vec3 d = mid + along * u(rng) * (b - a) - 0.5 * s + 0.7 * fold * n;
    Eigen::Matrix<double, 3, 4> g, g_ad;
    Matrix12d h, h_ad;
    const double q = hinge_length_angle_hessian(a, b, c, d, &g, &h);
    const double q_ad = hinge_length_angle_hessian_autodiff(a, b, c, d, &g_ad, &h_ad);
    const double theta = std::abs(q) / (b - a).norm();
    largest_theta = std::max(largest_theta, theta);
    smallest_theta = std::min(smallest_theta, theta);
    EXPECT_NEAR(q, q_ad, 1e-15 * (1.0 + std::abs(q_ad)));
    EXPECT_LT((g - g_ad).norm(), 1e-14 * (1.0 + g_ad.norm())) << "trial " << trial;
    EXPECT_LT((h - h_ad).norm(), 1e-13 * h_ad.norm()) << "trial " << trial;
    EXPECT_EQ((h - h.transpose()).norm(), 0.0);
    ++checked;
  }
  EXPECT_EQ(checked, 200);
  EXPECT_LT(smallest_theta, 1e-5);  // the nearly-flat hinges were exercised
  EXPECT_GT(largest_theta, 0.5);    // and strongly folded ones
}

TEST(HelfrichHessian, JuelicherHessianMatchesFiniteDifferencesWithSpontaneousCurvature) {
  TriMesh m = testing::sphere_mesh(3, 2.0);
  testing::perturb(m.x, 0.05, 21);
  const BendingParameters p{0.2, 0.4};
  auto grad_of = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    const Positions x = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, m.x.cols());
    Positions g = Positions::Zero(3, x.cols());
    juelicher_bending_energy(x, m.topo, p, &g);
    return flat(g);
  };
  BlockHessian h(m.topo);
  h.set_zero();
  add_juelicher_hessian(m.x, m.topo, p, h);
  const Eigen::SparseMatrix<double>& hm = h.matrix();
  const Eigen::SparseMatrix<double> asym = hm - Eigen::SparseMatrix<double>(hm.transpose());
  EXPECT_LT(asym.norm(), 1e-12 * hm.norm());
  for (unsigned s = 0; s < 3; ++s)
    testing::expect_hessian_ok(
        testing::check_hessian_direction(
            grad_of, flat(m.x), [&](const Eigen::VectorXd& d) -> Eigen::VectorXd { return hm * d; },
            0.7, s),
        "Juelicher Helfrich energy");
}

// The fused Lagrangian Hessian on 1 thread (serial path) and on 2 and 3 threads (element
// matrices on the threads, every thread adding into its share of the blocks): the same bits,
// in both storages. 3 threads split the blocks unevenly, so a share boundary that dropped or
// doubled a block would show.
TEST(HelfrichHessian, LagrangianHessianBitIdenticalWithOneTwoThreeThreads) {
  TriMesh mesh = testing::sphere_mesh(6, 3.0);  // 720 faces
  const ContinuumModel m = build_continuum_model(mesh, testing::closed_form_p2_law(), {});
  ASSERT_GT(m.num_elements(), 256);  // above the serial threshold of add_lagrangian_hessian
  Positions x = m.rest;
  testing::perturb(x, 0.05, 9);
  const int saved = omp_get_max_threads();
  for (BlockStorage storage : {BlockStorage::full, BlockStorage::lower}) {
    std::vector<Eigen::VectorXd> values;
    for (int t = 1; t <= 3; ++t) {
      omp_set_num_threads(t);
      BlockHessian h(m.topo, storage);
      for (int rep = 0; rep < 2; ++rep) {  // the second assembly reuses the kept buffers
        h.set_zero();
        add_lagrangian_hessian(m, x, 0.3, -0.02, h);
      }
      values.emplace_back(
          Eigen::Map<const Eigen::VectorXd>(h.matrix().valuePtr(), h.matrix().nonZeros()));
    }
    omp_set_num_threads(saved);
    EXPECT_GT(values[0].norm(), 0.0);
    for (int t = 1; t < 3; ++t) EXPECT_TRUE((values[t].array() == values[0].array()).all());
  }
}

}  // namespace
}  // namespace rbc
