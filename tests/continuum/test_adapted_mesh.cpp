// SPDX-License-Identifier: GPL-3.0-or-later
// Meshes graded to the stretch scene (continuum/adapted_mesh.hpp): the level function against
// the parametrised surface, the meshed area and volume against the Evans-Fung closed form
// under refinement, element sizes following the size field, a closed outward-oriented genus-0
// manifold, the same mesh for the same seed, and a continuum stretch on it holding its
// constraints.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "continuum/adapted_mesh.hpp"
#include "continuum/contact_load.hpp"
#include "continuum/continuum_stretch.hpp"
#include "discrete/network.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc {
namespace adapted_mesh_test {
namespace {

/// A uniform-size field (um).
SizeField uniform(double h_um) {
  return [h_um](const Vec3&) { return h_um; };
}

TEST(AdaptedMesh, LevelFunctionVanishesOnTheSurfaceOnlyAndGradientMatches) {
  const EvansFungShape shape;
  const TriMesh sphere = make_icosphere(6);
  for (Eigen::Index i = 0; i < sphere.x.cols(); ++i) {
    const Vec3 p = evans_fung_point(shape, sphere.x.col(i));
    EXPECT_NEAR(evans_fung_level(shape, p), 0.0, 1e-14);
    // Inside (scaled towards the centre) negative, outside positive.
    EXPECT_LT(evans_fung_level(shape, 0.9 * p), 0.0);
    EXPECT_GT(evans_fung_level(shape, 1.1 * p), 0.0);
    // The gradient against central differences (away from the t = 1 kink in the field).
    const Vec3 q = 1.05 * p;
    if (std::abs(std::hypot(q.x(), q.y()) - shape.radius_um) < 0.05) continue;
    Vec3 fd;
    const double d = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Vec3 a = q, b = q;
      a(k) += d;
      b(k) -= d;
      fd(k) = (evans_fung_level(shape, a) - evans_fung_level(shape, b)) / (2 * d);
    }
    EXPECT_LT((fd - evans_fung_level_gradient(shape, q)).norm(), 1e-7);
  }
  // No spurious zero beyond the rim, where g(t) vanishes (t ~ 1.88).
  for (double r = 1.01; r < 2.0; r += 0.01)
    EXPECT_GT(evans_fung_level(shape, Vec3(r * shape.radius_um, 0, 0)), 0.0);
}

TEST(AdaptedMesh, ClosedOutwardGenusZeroManifoldOnTheSurface) {
  const EvansFungShape shape;
  for (double h : {0.8, 0.4, 0.2}) {
    const TriMesh m = mesh_evans_fung_surface(shape, uniform(h));
    // build_topology (run by the mesher) already refused non-manifold or inconsistent meshes;
    // here the independent counts: every edge in two faces, V - E + F = 2.
    EXPECT_EQ(2 * m.topo.num_edges(), 3 * m.topo.num_faces());
    EXPECT_EQ(m.topo.num_vertices - m.topo.num_edges() + m.topo.num_faces(), 2);
    EXPECT_GT(enclosed_volume(m.x, m.topo), 0.0);  // outward
    // Each face normal points away from the enclosed region: along the level gradient.
    int inward = 0;
    for (int f = 0; f < m.topo.num_faces(); ++f) {
      const Vec3 a = m.x.col(m.topo.faces(0, f)), b = m.x.col(m.topo.faces(1, f)),
                 c = m.x.col(m.topo.faces(2, f));
      const Vec3 n = (b - a).cross(c - a);
      if (n.dot(evans_fung_level_gradient(shape, (a + b + c) / 3.0)) <= 0) ++inward;
    }
    EXPECT_EQ(inward, 0) << "h = " << h;
    for (Eigen::Index i = 0; i < m.x.cols(); ++i)
      EXPECT_NEAR(evans_fung_level(shape, m.x.col(i)), 0.0, 1e-13);
  }
}

TEST(AdaptedMesh, AreaAndVolumeConvergeToTheClosedForm) {
  const EvansFungShape shape;
  const EvansFungMeasures exact = evans_fung_measures(shape);
  double previous_area = 1, previous_volume = 1;
  for (double h : {0.8, 0.4, 0.2, 0.1}) {
    const TriMesh m = mesh_evans_fung_surface(shape, uniform(h));
    const double ea = std::abs(total_area(m.x, m.topo) / exact.area_um2 - 1);
    const double ev = std::abs(enclosed_volume(m.x, m.topo) / exact.volume_um3 - 1);
    std::cout << "h " << h << " um: " << m.topo.num_faces() << " faces, area error " << ea
              << ", volume error " << ev << "\n";
    // An inscribed surface loses area and volume at second order: about (h/R_curv)^2 / 8
    // with the smallest radius of curvature (1.1 um at the rim) bounding the constant.
    EXPECT_LT(ea, 0.1 * h * h);
    EXPECT_LT(ev, 0.1 * h * h);
    // Halving h divides the errors by about 4 (at least by 2.5).
    if (h < 0.8) {
      EXPECT_LT(ea, previous_area / 2.5);
      EXPECT_LT(ev, previous_volume / 2.5);
    }
    previous_area = ea, previous_volume = ev;
  }
}

TEST(AdaptedMesh, SameSeedSameMeshOtherSeedOtherMesh) {
  AdaptedMeshOptions o;
  o.target_elements = 1000;
  const TriMesh a = make_adapted_mesh(o), b = make_adapted_mesh(o);
  ASSERT_EQ(a.x.cols(), b.x.cols());
  ASSERT_EQ(a.topo.faces.cols(), b.topo.faces.cols());
  EXPECT_TRUE(a.x == b.x);
  EXPECT_TRUE(a.topo.faces == b.topo.faces);
  o.seed = 3;
  const TriMesh c = make_adapted_mesh(o);
  EXPECT_FALSE(c.x.cols() == a.x.cols() && c.x == a.x);
}

TEST(AdaptedMesh, ElementSizesFollowTheSizeField) {
  for (double ratio : {2.0, 3.0}) {
    AdaptedMeshOptions o;
    o.target_elements = 3000;
    o.size_ratio = ratio;
    AdaptedMeshReport r;
    const TriMesh m = make_adapted_mesh(o, &r);
    EXPECT_NEAR(r.elements, o.target_elements, o.element_tolerance * o.target_elements);
    const SceneSizeField& f = r.size;
    EXPECT_NEAR(f.coarse_um / f.fine_um, ratio, 1e-12);
    // The cap plane: 5 % of the mesh's area beyond it (to the discretisation).
    EXPECT_NEAR(cap_area(m.x, m.topo, f.plane_um * r.volume_scale, +1) / total_area(m.x, m.topo),
                0.05, 2e-3);
    const double fine = mean_edge_length(m, [&](const Vec3& p) {
      return std::abs(p.x()) >= (f.plane_um - f.band_um) * r.volume_scale;
    });
    const double coarse = mean_edge_length(m, [&](const Vec3& p) {
      return std::abs(p.x()) * r.volume_scale <
             f.plane_um - f.band_um - (f.coarse_um - f.fine_um) / f.grading;
    });
    std::cout << "ratio " << ratio << ": " << r.elements << " elements, fine " << fine
              << " um (h_f " << f.fine_um << "), coarse " << coarse << " um (h_c " << f.coarse_um
              << "), passes " << r.passes << "\n";
    // h bounds the size (surface Delaunay balls of radius <= h/sqrt(3)); refinement stops
    // once every facet is below it, so the mean edge in each region lies between 0.6 h and
    // h, and the ratio of the two within 15 % of the prescribed one.
    EXPECT_GT(fine / f.fine_um, 0.6);
    EXPECT_LT(fine / f.fine_um, 1.0);
    EXPECT_GT(coarse / f.coarse_um, 0.6);
    EXPECT_LT(coarse / f.coarse_um, 1.0);
    EXPECT_NEAR(coarse / fine / ratio, 1.0, 0.15);
  }
}

TEST(AdaptedMesh, OptionsOutOfRangeAreRefused) {
  AdaptedMeshOptions o;
  o.size_ratio = 0.5;
  EXPECT_THROW(o.validate(), InvalidParameter);
  o = {};
  o.target_elements = 100;
  EXPECT_THROW(o.validate(), InvalidParameter);
  o = {};
  o.contact_fraction = 0.6;
  EXPECT_THROW(o.validate(), InvalidParameter);
  EXPECT_THROW(mesh_evans_fung_surface(EvansFungShape{}, uniform(-1.0)), std::invalid_argument);
}

TEST(AdaptedMesh, StretchHoldsTheConstraints) {
  AdaptedMeshOptions o;
  o.target_elements = 800;
  const TriMesh mesh = make_adapted_mesh(o);
  ContinuumParameters p;
  const ContinuumModel model = build_continuum_model(
      mesh,
      make_membrane_law(NetworkParameters{}.wlc, NetworkParameters{}.steric, WlcExpansion::full),
      p);
  ContinuumOptions co;
  co.load = ContinuumLoad::exact_contact;
  co.measure = ContinuumMeasure::quadric_fit;
  const auto pts = run_continuum_stretch(model, {0.0, 100.0, 193.0}, co);
  for (const auto& pt : pts) {
    EXPECT_TRUE(pt.converged) << pt.force_pN;
    EXPECT_LT(std::abs(pt.area_drift), 1e-9);
    EXPECT_LT(std::abs(pt.volume_drift), 1e-9);
    EXPECT_LT(pt.residual_pN, co.newton.force_tolerance_pN * 1.0001);
  }
  // Stretched along x, narrowed along y.
  EXPECT_GT(pts[2].axial_um, pts[0].axial_um + 5.0);
  EXPECT_LT(pts[2].transverse_um, pts[0].transverse_um - 1.5);
}

}  // namespace
}  // namespace adapted_mesh_test
}  // namespace rbc
