// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <random>

#include "core/geometry.hpp"
#include "core/units.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

TEST(Geometry, SphereAreaAndVolumeConvergeAtSecondOrder) {
  // Inscribed polyhedra of a sphere: errors in area and volume fall as h^2.
  const double r = 2.7;
  double prev_area_err = 0, prev_vol_err = 0;
  for (int f : {4, 8, 16}) {
    const TriMesh m = testing::sphere_mesh(f, r);
    const double area_err = std::abs(total_area(m.x, m.topo) / (4 * units::pi * r * r) - 1);
    const double vol_err =
        std::abs(enclosed_volume(m.x, m.topo) / (4.0 / 3.0 * units::pi * r * r * r) - 1);
    if (prev_area_err > 0) {
      EXPECT_NEAR(prev_area_err / area_err, 4.0, 0.6) << "frequency " << f;
      EXPECT_NEAR(prev_vol_err / vol_err, 4.0, 0.6) << "frequency " << f;
    }
    prev_area_err = area_err;
    prev_vol_err = vol_err;
  }
  EXPECT_LT(prev_area_err, 5e-3);
}

TEST(Geometry, IcosphereIsClosedGenusZero) {
  for (int f : {1, 2, 5, 7}) {
    const TriMesh m = make_icosphere(f);
    EXPECT_EQ(m.topo.num_vertices, 10 * f * f + 2);
    EXPECT_EQ(m.topo.num_vertices - m.topo.num_edges() + m.topo.num_faces(), 2);
    EXPECT_GT(enclosed_volume(m.x, m.topo), 0.0);  // outward orientation
  }
}

// Gradient of a scalar kernel of k points, checked by central differences on random,
// non-symmetric configurations with the step from machine precision (h ~ cbrt(eps)).
template <int K, class Kernel>
void check_kernel_gradient(Kernel kernel, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix<double, 3, K> p;
  for (int i = 0; i < 3 * K; ++i) p.data()[i] = u(rng);
  Eigen::Matrix<double, 3, K> g;
  kernel(p, &g);
  const double h = std::cbrt(std::numeric_limits<double>::epsilon());
  for (int i = 0; i < 3 * K; ++i) {
    auto q = p;
    q.data()[i] += h;
    const double fp = kernel(q, nullptr);
    q.data()[i] -= 2 * h;
    const double fm = kernel(q, nullptr);
    EXPECT_NEAR((fp - fm) / (2 * h), g.data()[i], 1e-8 * (1 + std::abs(g.data()[i])))
        << "entry " << i;
  }
}

TEST(Geometry, KernelGradientsMatchFiniteDifferences) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    check_kernel_gradient<3>(
        [](const Eigen::Matrix3d& p, Eigen::Matrix3d* g) {
          return triangle_area(p.col(0), p.col(1), p.col(2), g);
        },
        seed);
    check_kernel_gradient<3>(
        [](const Eigen::Matrix3d& p, Eigen::Matrix3d* g) {
          return tetra_volume(p.col(0), p.col(1), p.col(2), g);
        },
        seed);
    check_kernel_gradient<4>(
        [](const Eigen::Matrix<double, 3, 4>& p, Eigen::Matrix<double, 3, 4>* g) {
          return dihedral_angle(p.col(0), p.col(1), p.col(2), p.col(3), g);
        },
        seed);
  }
}

TEST(Geometry, DihedralAngleSignAndValue) {
  // A roof ridge along x: faces slope down at 45 degrees on either side -> theta = pi/2.
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0.5, 1, -1), d(0.5, -1, -1);
  EXPECT_NEAR(dihedral_angle(a, b, c, d), units::pi / 2, 1e-12);
  // Valley (concave): mirror in z.
  EXPECT_NEAR(dihedral_angle(a, b, Vec3(0.5, 1, 1), Vec3(0.5, -1, 1)), -units::pi / 2, 1e-12);
}

TEST(Geometry, PhiVanishesOnlyForEquilateralAndHasCorrectGradient) {
  TriMesh m = testing::sphere_mesh(3, 1.0);
  EXPECT_GT(equilateral_defect(m.x, m.topo), 0.0);
  testing::perturb(m.x, 0.02, 7);
  Positions g;
  equilateral_defect(m.x, m.topo, &g);
  const Eigen::VectorXd x0 = flat(m.x);
  auto f = [&](const Eigen::VectorXd& v) {
    Positions p = Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, m.x.cols());
    return equilateral_defect(p, m.topo);
  };
  const double h = 1e-5;
  EXPECT_LT(testing::fd_gradient_error(f, x0, flat(g), h, 60, 3), 1e-7);
}

}  // namespace
}  // namespace rbc

namespace rbc {
namespace {
TEST(Geometry, TransverseDiameterIgnoresRotationAboutTheStretchAxis) {
  // A flat ellipse-like disc: 8 um along x, 6 um along y, 2 um thick in z.
  Positions x(3, 400);
  for (int k = 0; k < 400; ++k) {
    const double t = 2 * units::pi * k / 400.0;
    x.col(k) << 4 * std::cos(t), 3 * std::sin(t), (k % 2 ? 1.0 : -1.0) * 0.2 * std::cos(t);
  }
  const Diameters d0 = measure_diameters(x);
  EXPECT_NEAR(d0.axial_um, 8.0, 1e-9);
  EXPECT_NEAR(d0.transverse_um, 6.0, 1e-3);
  // Rotating about x changes max y - min y but not the transverse diameter.
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Diameters d1 = measure_diameters(r * x);
  EXPECT_NEAR(d1.axial_um, d0.axial_um, 1e-12);
  EXPECT_NEAR(d1.transverse_um, d0.transverse_um, 1e-6);
  const Positions rx = r * x;
  EXPECT_LT(rx.row(1).maxCoeff() - rx.row(1).minCoeff(), 5.5);  // the naive y extent shrinks
}
}  // namespace
}  // namespace rbc

namespace rbc {
namespace {

TEST(Diameters, TransverseIsTheLargestProjectedDistance) {
  // D_T = max over directions u in the y-z plane of the extent along u = the largest distance
  // between two points projected on that plane: brute force over all pairs, and a fine scan
  // of directions from below.
  std::mt19937 rng(9);
  std::normal_distribution<double> nd;
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 3 + trial * 17;
    Positions x(3, n);
    for (int i = 0; i < n; ++i) x.col(i) = Eigen::Vector3d(nd(rng), 2.0 * nd(rng), 0.5 * nd(rng));
    double pair = 0.0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        pair = std::max(pair, (x.block<2, 1>(1, i) - x.block<2, 1>(1, j)).norm());
    double scan = 0.0;
    for (int k = 0; k < 20000; ++k) {
      const double phi = 3.14159265358979323846 * k / 20000;
      const Eigen::RowVectorXd p = std::cos(phi) * x.row(1) + std::sin(phi) * x.row(2);
      scan = std::max(scan, p.maxCoeff() - p.minCoeff());
    }
    const Diameters d = measure_diameters(x);
    EXPECT_NEAR(d.transverse_um, pair, 1e-12 * pair) << n << " points";
    EXPECT_LE(scan, d.transverse_um * (1 + 1e-12));
    EXPECT_GT(scan, d.transverse_um * (1 - 1e-6));
    EXPECT_DOUBLE_EQ(d.axial_um, x.row(0).maxCoeff() - x.row(0).minCoeff());
  }
  // Clouds whose extreme points tie (a square lattice: the points dropped as inside the octagon of
  // extremes must leave the hull as it is) and a ring around a dense interior.
  auto brute = [](const Positions& x) {
    double pair = 0.0;
    for (Eigen::Index i = 0; i < x.cols(); ++i)
      for (Eigen::Index j = 0; j < x.cols(); ++j)
        pair = std::max(pair, (x.block<2, 1>(1, i) - x.block<2, 1>(1, j)).norm());
    return pair;
  };
  Positions lattice(3, 121);
  for (int i = 0; i < 11; ++i)
    for (int j = 0; j < 11; ++j) lattice.col(11 * i + j) = Eigen::Vector3d(0.0, i - 5.0, j * 0.5);
  EXPECT_DOUBLE_EQ(measure_diameters(lattice).transverse_um, brute(lattice));
  Positions ring(3, 400);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 400; ++i) {
    const double phi = 2 * 3.14159265358979323846 * u(rng), r = i < 40 ? 3.0 : 2.9 * u(rng);
    ring.col(i) = Eigen::Vector3d(u(rng), r * std::cos(phi), 0.4 * r * std::sin(phi));
  }
  EXPECT_DOUBLE_EQ(measure_diameters(ring).transverse_um, brute(ring));
  // Collinear and repeated points (degenerate hulls).
  Positions line(3, 4);
  line << 0, 1, 2, 3, 0, 1, 1, 3, 0, 2, 2, 6;
  EXPECT_NEAR(measure_diameters(line).transverse_um, std::sqrt(9.0 + 36.0), 1e-14);
}

}  // namespace
}  // namespace rbc
