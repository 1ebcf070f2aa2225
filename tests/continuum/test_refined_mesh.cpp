// SPDX-License-Identifier: GPL-3.0-or-later
// Mirror-symmetric graded meshes (continuum/refined_mesh.hpp): a closed outward-oriented genus-0
// manifold on the Evans-Fung surface, the coarse mesh's mirror group kept (4 elements on the
// default icosphere, 8 on the mirror-planes one), area and volume converging to the closed form
// as the field is refined, element sizes following the field, the element count near its
// target, and a mirror-reduced continuum stretch on it agreeing with the full one.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "continuum/adapted_mesh.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/refined_mesh.hpp"
#include "core/geometry.hpp"
#include "core/mirror_symmetry.hpp"
#include "discrete/network.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc {
namespace refined_mesh_test {
namespace {

/// Coarse uniform mesh on the surface (not volume-matched) of the given frequency.
TriMesh coarse_mesh(int frequency, TriangulationOrientation orientation) {
  RestShapeOptions ro;
  ro.target_vertices = 10 * frequency * frequency + 2;
  ro.orientation = orientation;
  ro.match_volume = false;
  return make_rest_shape(ro);
}

/// Independent manifold checks: every edge in two faces traversed once each way, V - E + F = 2,
/// positive enclosed volume (outward), every vertex on the Evans-Fung surface.
void expect_closed_outward_sphere(const TriMesh& m, double scale = 1.0) {
  std::map<std::pair<int, int>, int> directed;
  for (int f = 0; f < m.topo.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[{m.topo.faces(k, f), m.topo.faces((k + 1) % 3, f)}];
  int edges = 0;
  for (const auto& [e, n] : directed) {
    EXPECT_EQ(n, 1) << "edge traversed twice the same way";
    EXPECT_EQ(directed.count({e.second, e.first}), 1u) << "boundary edge";
    if (e.first < e.second) ++edges;
  }
  EXPECT_EQ(m.topo.num_vertices - edges + m.topo.num_faces(), 2);
  EXPECT_GT(enclosed_volume(m.x, m.topo), 0.0);
  const EvansFungShape shape;
  for (Eigen::Index i = 0; i < m.x.cols(); ++i)
    ASSERT_NEAR(evans_fung_level(shape, m.x.col(i) / scale), 0.0, 1e-12) << "vertex " << i;
}

TEST(RefinedMesh, SizeFieldIsMirrorInvariantAndFineWhereItShouldBe) {
  RefinedSizeField h;
  h.fine_um = 0.25;
  h.plane_um = 3.4;
  h.band_um = 0.25;
  h.rim_y_um = 3.91;
  h.rim_band_um = 0.5;
  h.grading = 0.5;
  for (const Vec3& p : {Vec3(1.0, 2.0, 0.5), Vec3(3.5, 0.3, -0.2), Vec3(0.1, -3.8, 0.3)})
    for (int mask = 0; mask < 8; ++mask) {
      Vec3 q = p;
      for (int k = 0; k < 3; ++k) q(k) *= reflection_sign(mask, k);
      EXPECT_EQ(h(q), h(p));
    }
  EXPECT_DOUBLE_EQ(h(Vec3(3.3, 0.0, 0.0)), 0.25);   // inside the cap band
  EXPECT_DOUBLE_EQ(h(Vec3(0.0, -3.6, 0.2)), 0.25);  // near a D_T rim point
  EXPECT_DOUBLE_EQ(h(Vec3(0.0, 0.0, 1.0)),
                   0.25 + 0.5 * std::min(3.15, std::hypot(3.91, 1.0) - 0.5));
}

TEST(RefinedMesh, KeepsTheCoarseMirrorGroupAndIsAClosedManifold) {
  const EvansFungShape shape;
  for (auto orientation :
       {TriangulationOrientation::dimple_vertex, TriangulationOrientation::mirror_planes}) {
    const TriMesh coarse = coarse_mesh(7, orientation);
    const int coarse_order = find_mirror_symmetry(coarse.x, coarse.topo).order();
    EXPECT_EQ(coarse_order, orientation == TriangulationOrientation::dimple_vertex ? 4 : 8);
    RefinedSizeField h;
    h.plane_um = rest_contact_plane(shape, 0.05);
    h.fine_um = 0.2;
    h.band_um = 0.2;
    h.rim_band_um = 0.4;
    const TriMesh m = refine_evans_fung_mesh(coarse, shape, h, 6);
    EXPECT_GT(m.topo.num_faces(), 2 * coarse.topo.num_faces());  // it did refine
    expect_closed_outward_sphere(m);
    const MeshSymmetry s = find_mirror_symmetry(m.x, m.topo);
    EXPECT_EQ(s.order(), coarse_order) << to_string(orientation);
  }
}

TEST(RefinedMesh, SizesFollowTheField) {
  const EvansFungShape shape;
  const TriMesh coarse = coarse_mesh(6, TriangulationOrientation::dimple_vertex);
  RefinedSizeField h;
  h.plane_um = rest_contact_plane(shape, 0.05);
  h.fine_um = 0.15;
  h.band_um = 0.15;
  h.rim_band_um = 0.3;
  const TriMesh m = refine_evans_fung_mesh(coarse, shape, h, 8);
  // Every triangle is a red triangle whose equivalent edge is at most the field at its
  // centroid, or one green half of such a triangle (smaller than it): at most the field's, up to
  // the field's change between a green half's centroid and its parent's.
  double worst = 0;
  for (int f = 0; f < m.topo.num_faces(); ++f) {
    const Vec3 a = m.x.col(m.topo.faces(0, f)), b = m.x.col(m.topo.faces(1, f)),
               c = m.x.col(m.topo.faces(2, f));
    const double s = std::sqrt(4.0 / std::sqrt(3.0) * triangle_area(a, b, c));
    worst = std::max(worst, s / h((a + b + c) / 3.0));
  }
  EXPECT_LT(worst, 1.2);
  // Fine where the field is fine, and coarse (the coarse mesh's size) where it is coarse.
  const double fine = mean_edge_length(m, [&](const Vec3& p) { return h(p) <= h.fine_um; });
  // Far from the fine regions (the dimples) the coarse mesh is left as it is.
  const double coarse_edge = mean_edge_length(coarse, [](const Vec3&) { return true; });
  auto far_away = [&](const Vec3& p) { return h(p) > 2.0 * coarse_edge; };
  const double far = mean_edge_length(m, far_away);
  const double far_coarse = mean_edge_length(coarse, far_away);
  ASSERT_GT(far_coarse, 0.0);
  EXPECT_LT(fine, 1.05 * h.fine_um);
  EXPECT_GT(fine, 0.4 * h.fine_um);  // not refined more than a level beyond the field
  EXPECT_NEAR(far, far_coarse, 0.02 * far_coarse);
}

TEST(RefinedMesh, AreaAndVolumeConvergeToTheClosedForm) {
  const EvansFungShape shape;
  const EvansFungMeasures exact = evans_fung_measures(shape);
  const TriMesh coarse = coarse_mesh(5, TriangulationOrientation::dimple_vertex);
  double last_area = 1, last_volume = 1;
  for (double fine : {0.4, 0.2, 0.1, 0.05}) {
    RefinedSizeField h;  // a nearly uniform field: fine everywhere up to twice fine
    h.fine_um = fine;
    h.grading = 1e-3;
    const TriMesh m = refine_evans_fung_mesh(coarse, shape, h, 10);
    const double da = std::abs(total_area(m.x, m.topo) / exact.area_um2 - 1);
    const double dv = std::abs(enclosed_volume(m.x, m.topo) / exact.volume_um3 - 1);
    // An inscribed mesh loses area and volume at second order in h: each halving of the
    // field divides the error by about 4 (at least 3).
    EXPECT_LT(da, last_area / 3.0) << fine;
    EXPECT_LT(dv, last_volume / 3.0) << fine;
    last_area = da;
    last_volume = dv;
  }
  EXPECT_LT(last_area, 2e-4);
  EXPECT_LT(last_volume, 2e-4);
}

// The default mesh keeps its vertices on the surface, so it encloses less than the surface
// (the chords cut inside the convex rim); with match_volume it is the same mesh scaled about
// the centre by s = (V / V_surface)^(1/3), enclosing the Evans-Fung volume.
TEST(RefinedMesh, MakeRefinedMeshMeetsItsTargetOnTheSurfaceOrScaledToTheVolume) {
  const EvansFungMeasures exact = evans_fung_measures(EvansFungShape{});
  for (int target : {2500, 4500}) {
    RefinedMeshOptions o;
    o.target_elements = target;
    RefinedMeshReport rep;
    const TriMesh m = make_refined_mesh(o, &rep);
    EXPECT_EQ(rep.elements, m.topo.num_faces());
    EXPECT_NEAR(m.topo.num_faces(), target, 0.2 * target);
    EXPECT_GT(rep.elements, rep.coarse_elements);
    EXPECT_EQ(rep.volume_scale, 1.0);
    const double v_surface = enclosed_volume(m.x, m.topo);
    EXPECT_LT(v_surface, exact.volume_um3);
    EXPECT_GT(v_surface, 0.99 * exact.volume_um3);
    expect_closed_outward_sphere(m);
    EXPECT_EQ(find_mirror_symmetry(m.x, m.topo).order(), 4);

    o.match_volume = true;
    RefinedMeshReport scaled_rep;
    const TriMesh scaled = make_refined_mesh(o, &scaled_rep);
    ASSERT_TRUE(scaled.topo.faces == m.topo.faces);
    EXPECT_NEAR(scaled_rep.volume_scale, std::cbrt(exact.volume_um3 / v_surface), 1e-12);
    EXPECT_LT((scaled.x - scaled_rep.volume_scale * m.x).cwiseAbs().maxCoeff(), 1e-13);
    EXPECT_NEAR(enclosed_volume(scaled.x, scaled.topo), exact.volume_um3, 1e-9 * exact.volume_um3);
    expect_closed_outward_sphere(scaled, scaled_rep.volume_scale);
  }
  RefinedMeshOptions bad;
  bad.size_ratio = 0.5;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = {};
  bad.max_levels = 11;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = {};
  bad.target_elements = 100;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  EXPECT_THROW(refine_evans_fung_mesh(
                   make_icosphere(2), EvansFungShape{}, [](const Vec3&) { return 1.0; }, -1),
               std::invalid_argument);
}

// The turns of one request (RefinedMeshOptions::seed) are turns of the unturned request's coarse
// icosphere: the same frequency, the vertices turned, the refined count within a few % (the rims
// cut other triangles), and no mirror plane left. At 1,000 triangles and size ratio 1 a turned
// mesh's own frequency search would land on f = 4 (828 triangles) while the unturned one takes f
// = 5.
TEST(RefinedMesh, TurnsOfARequestShareItsCoarseIcosphere) {
  for (int target : {1000, 2000}) {
    RefinedMeshOptions o;
    o.target_elements = target;
    o.size_ratio = 1.0;
    RefinedMeshReport unturned;
    make_refined_mesh(o, &unturned);
    for (unsigned seed : {1u, 2u, 3u}) {
      o.seed = seed;
      RefinedMeshReport rep;
      const TriMesh m = make_refined_mesh(o, &rep);
      EXPECT_EQ(rep.coarse_vertices, unturned.coarse_vertices) << target << " seed " << seed;
      EXPECT_EQ(rep.coarse_elements, unturned.coarse_elements);
      EXPECT_NEAR(rep.elements, unturned.elements, 0.1 * unturned.elements);
      expect_closed_outward_sphere(m);
      // At most the central inversion is left (the icosahedron and the cell share it).
      EXPECT_LE(find_mirror_symmetry(m.x, m.topo).order(), 2);
    }
  }
}

// The mirror-reduced solve on the refined mesh finds the full solve's equilibrium.
TEST(RefinedMesh, MirrorStretchOnItAgreesWithTheFullOne) {
  RefinedMeshOptions o;
  o.target_elements = 2000;
  const TriMesh mesh = make_refined_mesh(o);
  const NetworkParameters p;
  ContinuumParameters cp;
  cp.bending = p.bending;
  cp.tweezers = p.tweezers;
  const ContinuumModel model =
      build_continuum_model(mesh, make_membrane_law(p.wlc, p.steric, WlcExpansion::full), cp);
  ContinuumOptions full;
  ContinuumOptions mirror;
  mirror.newton.symmetry = Symmetry::mirror;
  const std::vector<double> forces = {0.0, 88.0};
  const auto a = run_continuum_stretch(model, forces, full);
  const auto b = run_continuum_stretch(model, forces, mirror);
  ASSERT_EQ(a.size(), forces.size());
  ASSERT_EQ(b.size(), forces.size());
  for (std::size_t k = 0; k < forces.size(); ++k) {
    ASSERT_TRUE(a[k].converged && b[k].converged) << forces[k];
    EXPECT_NEAR(a[k].axial_um, b[k].axial_um, 1e-6 * a[k].axial_um) << forces[k];
    EXPECT_NEAR(a[k].transverse_um, b[k].transverse_um, 1e-6 * a[k].transverse_um) << forces[k];
  }
  EXPECT_GE(b.back().symmetry_order, 2);  // the reduced solve ran on a mirror group
  EXPECT_GT(b.back().axial_um, a.front().axial_um + 1.0);  // it stretched
}

}  // namespace
}  // namespace refined_mesh_test
}  // namespace rbc
