// SPDX-License-Identifier: GPL-3.0-or-later
// The quadric-fitted surface extent (continuum/surface_extent.hpp) against closed forms: an
// ellipsoid's diameters 2a and 2 max(b, c) under refinement and random turns of the
// triangulation (observed order against the vertex measure's), and the Evans-Fung rest cell's
// diameter (MODEL.md section 1) on the continuum's own meshes.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <iostream>
#include <random>

#include "continuum/continuum_model.hpp"
#include "continuum/surface_extent.hpp"
#include "core/rest_shape.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace surface_extent_test {
namespace {

using testing::random_rotation;

constexpr double kA = 4.0, kB = 3.0, kC = 2.0;  // semi-axes (um): D_A = 8, D_T = 6

/// The icosphere of the given frequency, turned at random, mapped onto the ellipsoid
/// x^2/a^2 + y^2/b^2 + z^2/c^2 = 1 (every vertex exactly on it).
TriMesh ellipsoid(int frequency, unsigned seed) {
  TriMesh m = make_icosphere(frequency);
  m.x = Eigen::Vector3d(kA, kB, kC).asDiagonal() * (random_rotation(seed) * m.x);
  return m;
}

struct Errors {
  double fitted = 0, vertices = 0;  ///< worst over turns of |D - closed form|, D_A and D_T
};

Errors worst_errors(int frequency) {
  Errors e;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    const TriMesh m = ellipsoid(frequency, seed);
    const Diameters f = surface_diameters(m.x, m.topo), v = measure_diameters(m.x);
    e.fitted =
        std::max({e.fitted, std::abs(f.axial_um - 2 * kA), std::abs(f.transverse_um - 2 * kB)});
    e.vertices =
        std::max({e.vertices, std::abs(v.axial_um - 2 * kA), std::abs(v.transverse_um - 2 * kB)});
  }
  return e;
}

TEST(SurfaceExtent, EllipsoidDiametersConvergeAtTheFitsOrder) {
  // Frequencies 8, 16, 32, 64 (h halves each time): the worst error over six turns of the
  // triangulation. The vertex measure's error is O(h^2) (kappa d^2 / 2, d <= h the distance
  // from the extremal point to the nearest vertex) and depends on the turn; the fitted
  // surface's is O(h^3) or better.
  std::vector<Errors> e;
  for (int f : {8, 16, 32, 64}) e.push_back(worst_errors(f));
  for (size_t k = 0; k < e.size(); ++k)
    std::cout << "ellipsoid, frequency " << (8 << k) << ": worst |error| fitted " << e[k].fitted
              << " um, vertices " << e[k].vertices << " um\n";
  // Observed orders: step by step for the fit, over the whole range (least-squares slope of
  // log error against log h) for the vertices, whose error jumps with where the vertices fall.
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t k = 0; k < e.size(); ++k) {
    const double lx = -static_cast<double>(k), ly = std::log2(e[k].vertices);  // log2 h
    sx += lx;
    sy += ly;
    sxx += lx * lx;
    sxy += lx * ly;
  }
  const double n = static_cast<double>(e.size());
  const double vertex_order = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  std::cout << "  observed order: vertices " << vertex_order << " (slope over the range)\n";
  EXPECT_GT(vertex_order, 1.6);
  EXPECT_LT(vertex_order, 2.4);
  for (size_t k = 1; k < e.size(); ++k) {
    const double fitted_order = std::log2(e[k - 1].fitted / e[k].fitted);
    std::cout << "  observed order: fitted " << fitted_order << "\n";
    EXPECT_GT(fitted_order, 2.7);
    EXPECT_LT(e[k].fitted, 0.05 * e[k].vertices);
  }
}

TEST(SurfaceExtent, SupportOfASphereIsItsRadiusInEveryDirection) {
  // The support value of a sphere of radius r along any u is r; the vertices fall short by up
  // to r (1 - cos(h/r)).
  TriMesh m = make_icosphere(12);
  const double r_um = 3.0;
  m.x *= r_um;
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 20; ++k) {
    const Vec3 u = Vec3(n(rng), n(rng), n(rng)).normalized();
    const SurfaceSupport s = surface_support(m.x, m.topo, u);
    EXPECT_TRUE(s.fitted);
    EXPECT_NEAR(s.value_um, r_um, 2e-4);
    EXPECT_NEAR(s.point.norm(), r_um, 2e-4);
    EXPECT_GE(s.value_um, u.dot(m.x.col(s.vertex)));
  }
}

TEST(SurfaceExtent, EvansFungRestCellDiameterOnTheContinuumMeshes) {
  // The continuum's rest meshes sample the Evans-Fung surface (diameter 7.82 um) scaled about
  // its centre by MeshQualityReport::volume_scale (the volume match), so the smooth surface
  // the vertices lie on has diameter 7.82 x volume_scale in every direction of the x-y plane.
  const double d_um = evans_fung_measures(EvansFungShape{}).diameter_um;
  double worst_fit_2000 = 0, worst_vertex_2000 = 0;
  for (int elements : {1000, 2000})
    for (unsigned seed : {0u, 3u, 8u}) {
      MeshQualityReport report;
      const TriMesh m =
          make_continuum_mesh(elements, seed, TriangulationOrientation::dimple_vertex, &report);
      const double exact = d_um * report.volume_scale;
      const Diameters f = surface_diameters(m.x, m.topo), v = measure_diameters(m.x);
      const double ef = std::max(std::abs(f.axial_um - exact), std::abs(f.transverse_um - exact));
      const double ev = std::max(std::abs(v.axial_um - exact), std::abs(v.transverse_um - exact));
      EXPECT_LT(ef, elements == 1000 ? 5e-3 : 1e-3) << elements << " elements, seed " << seed;
      if (elements == 2000) {
        worst_fit_2000 = std::max(worst_fit_2000, ef);
        worst_vertex_2000 = std::max(worst_vertex_2000, ev);
      }
    }
  EXPECT_LT(worst_fit_2000, 0.1 * worst_vertex_2000);
}

}  // namespace
}  // namespace surface_extent_test
}  // namespace rbc
