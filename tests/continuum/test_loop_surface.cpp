// SPDX-License-Identifier: GPL-3.0-or-later
// The Loop subdivision limit surface (continuum/loop_surface.hpp) against independent truths:
// the box spline against the limit of repeated subdivision on a regular mesh (Loop's limit
// mask applied after two levels), irregular patches against the once-subdivided control mesh
// (same limit surface), partition of unity, and the interpolating surface's convergence to a
// sphere.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "continuum/loop_surface.hpp"
#include "core/geometry.hpp"
#include "core/rest_shape.hpp"
#include "core/validation.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

// A regular (all valence 6) triangulated torus of m x n vertices, radii 3 and 1 um.
TriMesh loop_regular_torus(int m, int n) {
  Positions x(3, m * n);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) {
      const double a = 2 * M_PI * i / m, b = 2 * M_PI * j / n;
      x.col(i * n + j) << (3 + std::cos(b)) * std::cos(a), (3 + std::cos(b)) * std::sin(a),
          std::sin(b);
    }
  Faces f(3, 2 * m * n);
  auto id = [&](int i, int j) { return ((i + m) % m) * n + (j + n) % n; };
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) {
      f.col(2 * (i * n + j)) << id(i, j), id(i + 1, j), id(i + 1, j + 1);
      f.col(2 * (i * n + j) + 1) << id(i, j), id(i + 1, j + 1), id(i, j + 1);
    }
  TriMesh t;
  t.x = x;
  t.topo = build_topology(f, m * n);
  return t;
}

// The corners (in the parent's (v, w)) of child k of a face with corners c (the numbering of
// loop_subdivide: corner children at a, b, c, then the middle one).
std::array<Eigen::Vector2d, 3> loop_child_corners(const std::array<Eigen::Vector2d, 3>& c, int k) {
  const Eigen::Vector2d ab = 0.5 * (c[0] + c[1]), bc = 0.5 * (c[1] + c[2]),
                        ca = 0.5 * (c[2] + c[0]);
  switch (k) {
    case 0:
      return {c[0], ab, ca};
    case 1:
      return {ab, c[1], bc};
    case 2:
      return {ca, bc, c[2]};
    default:
      return {ab, bc, ca};
  }
}

Vec3 loop_point(const LoopBasis& b, const Positions& x, int row = 0) {
  Vec3 p = Vec3::Zero();
  for (std::size_t k = 0; k < b.vertices.size(); ++k)
    p += b.shape(row, static_cast<Eigen::Index>(k)) * x.col(b.vertices[k]);
  return p;
}

TEST(LoopSurface, BoxSplineIsAPartitionOfUnityWithLoopsLimitMaskAtTheCorner) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 0.5);
  for (int s = 0; s < 20; ++s) {
    const auto n = loop_box_spline(u(rng), u(rng));
    EXPECT_NEAR(n.row(0).sum(), 1.0, 1e-14);
    for (int r = 1; r < 6; ++r) EXPECT_NEAR(n.row(r).sum(), 0.0, 1e-13);
  }
  // At corner a (index 3) the limit point is Loop's limit mask of valence 6: 1/2 on the vertex,
  // 1/12 on each of its ring (6, 7, 4, 1, 0, 2).
  const auto n0 = loop_box_spline(0, 0);
  for (int k = 0; k < 12; ++k) {
    const bool ring = k == 6 || k == 7 || k == 4 || k == 1 || k == 0 || k == 2;
    EXPECT_NEAR(n0(0, k), k == 3 ? 0.5 : (ring ? 1.0 / 12 : 0.0), 1e-15) << k;
  }
}

TEST(LoopSurface, BoxSplineDerivativesMatchFiniteDifferences) {
  const double v = 0.27, w = 0.31, h = 1e-4;
  using Basis = Eigen::Matrix<double, 6, 12>;
  const Basis n = loop_box_spline(v, w);
  const Basis dv = (loop_box_spline(v + h, w) - loop_box_spline(v - h, w)) / (2 * h);
  const Basis dw = (loop_box_spline(v, w + h) - loop_box_spline(v, w - h)) / (2 * h);
  EXPECT_LT((dv.row(0) - n.row(1)).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((dw.row(0) - n.row(2)).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((dv.row(1) - n.row(3)).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_LT((dw.row(1) - n.row(4)).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_LT((dv.row(2) - n.row(4)).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_LT((dw.row(2) - n.row(5)).cwiseAbs().maxCoeff(), 1e-7);
}

// On a regular mesh, the box spline of each face at the dyadic points (the corners of its
// level-2 descendants) equals the limit of subdividing the control mesh twice and applying
// Loop's limit mask: the coefficients and the patch's vertex order against subdivision itself.
TEST(LoopSurface, BoxSplineIsTheSubdivisionLimitOfARegularMesh) {
  TriMesh m = loop_regular_torus(6, 7);
  testing::perturb(m.x, 0.3, 11);
  const TriMesh m2 = loop_subdivide(loop_subdivide(m));
  const Positions limit2 = (loop_limit_matrix(m2.topo) * m2.x.transpose()).transpose();
  const Adjacency rings = loop_ordered_rings(m.topo);
  double worst = 0;
  int compared = 0;
  for (int f = 0; f < m.topo.num_faces(); ++f) {
    const std::array<int, 12> patch = loop_regular_patch(m.topo, rings, f);
    for (int k1 = 0; k1 < 4; ++k1)
      for (int k2 = 0; k2 < 4; ++k2) {
        const auto c = loop_child_corners(
            loop_child_corners(
                {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)}, k1),
            k2);
        const int fine = 4 * (4 * f + k1) + k2;
        for (int corner = 0; corner < 3; ++corner) {
          const auto n = loop_box_spline(c[corner](0), c[corner](1));
          Vec3 p = Vec3::Zero();
          for (int i = 0; i < 12; ++i) p += n(0, i) * m.x.col(patch[i]);
          worst = std::max(worst, (p - limit2.col(m2.topo.faces(corner, fine))).norm());
          ++compared;
        }
      }
  }
  EXPECT_EQ(compared, m.topo.num_faces() * 48);
  EXPECT_LT(worst, 1e-12);
}

// A point of a face next to an irregular vertex, evaluated on the control mesh (by subdivision
// inside LoopSubdivision) and on the once-subdivided mesh (the same limit surface) in the child
// that holds it: equal positions and derivatives (chain rule of the child's affine map).
TEST(LoopSurface, IrregularPatchesAgreeWithTheSubdividedMesh) {
  TriMesh m = make_icosphere(2);
  testing::perturb(m.x, 0.05, 3);
  const TriMesh fine = loop_subdivide(m);
  LoopSubdivision coarse_sub(m.topo, 4), fine_sub(fine.topo, 4);
  const double pts[5][2] = {{0.1, 0.1}, {0.8, 0.1}, {0.1, 0.8}, {0.3, 0.3}, {0.45, 0.05}};
  double worst = 0;
  int irregular = 0;
  for (int f = 0; f < m.topo.num_faces(); ++f) {
    bool reg = true;
    for (int k = 0; k < 3; ++k) reg = reg && m.topo.vertex_neighbours.size(m.topo.faces(k, f)) == 6;
    irregular += reg ? 0 : 1;
    for (const auto& p : pts) {
      const LoopBasis bc = coarse_sub.basis(f, p[0], p[1]);
      // The child holding the point, and the point's coordinates in it.
      const double u = 1 - p[0] - p[1];
      const int k = u > 0.5 ? 0 : (p[0] > 0.5 ? 1 : (p[1] > 0.5 ? 2 : 3));
      const auto c = loop_child_corners(
          {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)}, k);
      Eigen::Matrix2d jm;
      jm << c[1] - c[0], c[2] - c[0];
      const Eigen::Vector2d loc = jm.inverse() * (Eigen::Vector2d(p[0], p[1]) - c[0]);
      const LoopBasis bf = fine_sub.basis(4 * f + k, loc(0), loc(1));
      worst = std::max(worst, (loop_point(bc, m.x) - loop_point(bf, fine.x)).norm());
      // d/dl_m (child) = sum_k d/dxi_k J(k, m).
      for (int mm = 0; mm < 2; ++mm) {
        const Vec3 d = jm(0, mm) * loop_point(bc, m.x, 1) + jm(1, mm) * loop_point(bc, m.x, 2);
        worst = std::max(worst, (d - loop_point(bf, fine.x, 1 + mm)).norm());
      }
      const Vec3 dvv = loop_point(bc, m.x, 3), dvw = loop_point(bc, m.x, 4),
                 dww = loop_point(bc, m.x, 5);
      const int second[3][2] = {{0, 0}, {0, 1}, {1, 1}};
      for (int r = 0; r < 3; ++r) {
        const int a = second[r][0], b = second[r][1];
        const Vec3 d = jm(0, a) * jm(0, b) * dvv +
                       (jm(0, a) * jm(1, b) + jm(1, a) * jm(0, b)) * dvw +
                       jm(1, a) * jm(1, b) * dww;
        worst = std::max(worst, (d - loop_point(bf, fine.x, 3 + r)).norm());
      }
      EXPECT_NEAR(bc.shape.row(0).sum(), 1.0, 1e-13);
      EXPECT_NEAR(bc.shape.row(3).sum(), 0.0, 1e-11);
    }
  }
  EXPECT_GT(irregular, 0);
  EXPECT_LT(worst, 1e-10);
}

TEST(LoopSurface, BadPointsAndLevelsAreRefused) {
  const TriMesh m = make_icosphere(2);
  EXPECT_THROW(LoopSubdivision(m.topo, 9), InvalidParameter);
  LoopSubdivision sub(m.topo, 1);
  EXPECT_THROW(sub.basis(0, 0.0, 0.5), InvalidParameter);
  EXPECT_THROW(sub.basis(0, 0.6, 0.5), InvalidParameter);
  EXPECT_THROW(sub.basis(-1, 0.2, 0.2), InvalidParameter);
  // A point near an irregular corner needs more levels than one.
  int f = 0;
  while (m.topo.vertex_neighbours.size(m.topo.faces(0, f)) == 6) ++f;
  EXPECT_THROW(sub.basis(f, 0.05, 0.05), InvalidParameter);
}

// Control points that make the limit surface pass through icosphere vertices on a sphere of
// radius R: the limit surface's radial error at the quadrature points falls with h, at second
// order in the end: the surface is only C1 with bounded curvature at the 12 vertices of valence
// 5, where the worst error sits (about fourth order from frequency 4 to 8, before they dominate).
TEST(LoopSurface, InterpolatingSurfaceConvergesToTheSphere) {
  const double r = 2.5;
  std::vector<double> err;
  for (int freq : {4, 8, 16}) {
    const TriMesh m = testing::sphere_mesh(freq, r);
    const Positions ctrl = loop_interpolating_control_points(m.topo, m.x);
    // The limit points at the vertices are the targets.
    const Positions lim = (loop_limit_matrix(m.topo) * ctrl.transpose()).transpose();
    EXPECT_LT((lim - m.x).cwiseAbs().maxCoeff(), 1e-12);
    double worst = 0;
    for (const LoopQuadraturePoint& q : loop_quadrature(m.topo))
      worst = std::max(worst, std::abs(loop_point(q.basis, ctrl).norm() - r));
    err.push_back(worst / r);
  }
  const double p = std::log(err[1] / err[2]) / std::log(2.0);
  std::cout << "[ sphere ] interpolating limit surface, largest radial error " << err[0] << " "
            << err[1] << " " << err[2] << ", observed order " << p << "\n";
  EXPECT_GT(p, 1.6);
  EXPECT_LT(err[2], 5e-5);
}

// The diameters of the interpolating limit surface of an ellipsoid (semi-axes 4, 3, 1.5 um;
// icosphere vertices on it), measured on its exact points after three levels of subdivision
// (loop_limit_sampling_matrix): D_A = 8 um and D_T = 6 um (measure_diameters: extent along x, and
// the largest extent over the directions of the y-z plane) to the surface's order (measured
// 3.1e-4, 2.9e-5, 9.5e-6 at frequencies 4, 8, 16: about second order once the valence-5 vertices
// set the error, as for the sphere above).
TEST(LoopSurface, InterpolatedEllipsoidDiametersConvergeToTheClosedForm) {
  const Vec3 axes(4.0, 3.0, 1.5);
  std::vector<double> err;
  for (int freq : {4, 8, 16}) {
    TriMesh m = make_icosphere(freq);
    m.x = axes.asDiagonal() * testing::random_rotation(2) * m.x;  // no vertex at an extreme
    const Positions c = loop_interpolating_control_points(m.topo, m.x);
    const Eigen::SparseMatrix<double> sample = loop_limit_sampling_matrix(m.topo, 3);
    const Positions pts = (sample * c.transpose()).transpose();
    EXPECT_EQ(pts.cols(), 64 * (m.x.cols() - 2) + 2);  // V = 10 f^2 + 2 at frequency 8 f
    const Diameters d = measure_diameters(pts);
    err.push_back(std::max(std::abs(d.axial_um / 8.0 - 1), std::abs(d.transverse_um / 6.0 - 1)));
  }
  const double p = std::log(err[1] / err[2]) / std::log(2.0);
  std::cout << "[ ellipsoid ] diameters' relative errors " << err[0] << " " << err[1] << " "
            << err[2] << ", observed order " << p << "\n";
  EXPECT_LT(err[2], 2e-5);
  EXPECT_GT(p, 1.4);
}

}  // namespace
}  // namespace rbc
