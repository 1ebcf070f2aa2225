// SPDX-License-Identifier: GPL-3.0-or-later
// The exactly integrated bead contact load (continuum/contact_load.hpp): closed forms on one
// triangle, the prescribed total force and cap area on irregular meshes, continuity when the
// plane or the mesh moves, the whole-element limit, the first moment against the clipped
// region's centroid computed independently in Cartesian coordinates, and the stretch option.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <iostream>
#include <random>

#include "continuum/contact_load.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/surface_extent.hpp"
#include "fixtures.hpp"
#include "homogenise/invariant_laws.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace contact_load_test {
namespace {

using testing::random_rotation;

/// An irregular closed mesh: an icosphere of the given frequency turned at random, every
/// vertex moved tangentially and radially by up to 0.3 of the mean edge, then stretched into a
/// disc-like ellipsoid (semi-axes 4, 3.5, 1.5 um).
TriMesh irregular_mesh(int frequency, unsigned seed) {
  TriMesh m = make_icosphere(frequency);
  m.x = random_rotation(seed) * m.x;
  const double edge = 1.1 / frequency;  // about the unit icosphere's mean edge
  testing::perturb(m.x, 0.3 * edge, seed + 7);
  m.x = Eigen::Vector3d(4.0, 3.5, 1.5).asDiagonal() * m.x;
  return m;
}

double mean_edge(const TriMesh& m) {
  return edge_lengths(m.x, m.topo).mean();
}

double side_sum(const TweezerPatch& p, int side) {
  double s = 0;
  for (double w : p.share)
    if (w * side > 0) s += w;
  return s;
}

/// Dense nodal shares (size N) of one side.
Eigen::VectorXd dense_shares(const TweezerPatch& p, int n, int side) {
  Eigen::VectorXd s = Eigen::VectorXd::Zero(n);
  for (size_t k = 0; k < p.vertex.size(); ++k)
    if (p.share[k] * side > 0) s(p.vertex[k]) += p.share[k];
  return s;
}

TEST(ContactLoad, ClippedTriangleMatchesClosedForms) {
  // Right triangle A = (1,0,0), B = (0,0,0), C = (0,1,0) cut by x = 1/2: the tip at A is the
  // triangle (A, (1/2,0,0), (1/2,1/2,0)) of area 1/8; N_A takes 1, 1/2, 1/2 at its corners
  // (integral 1/8 x 2/3 = 1/12), N_B and N_C 0, 1/2, 0 and 0, 0, 1/2 (1/48 each).
  const Vec3 a(1, 0, 0), b(0, 0, 0), c(0, 1, 0);
  const ClippedTriangle tip = clip_triangle(a, b, c, 0.5, 1);
  EXPECT_NEAR(tip.area_um2, 1.0 / 8, 1e-15);
  EXPECT_NEAR(tip.shape_integral_um2(0), 1.0 / 12, 1e-15);
  EXPECT_NEAR(tip.shape_integral_um2(1), 1.0 / 48, 1e-15);
  EXPECT_NEAR(tip.shape_integral_um2(2), 1.0 / 48, 1e-15);
  // Cut at x = 3/4: the tip (A, (3/4,0,0), (3/4,1/4,0)) of area 1/32; N_A takes 1, 3/4, 3/4
  // (integral 1/32 x 5/6 = 5/192), N_B and N_C 1/4 at one corner (1/384 each).
  const ClippedTriangle small = clip_triangle(a, b, c, 0.75, 1);
  EXPECT_NEAR(small.area_um2, 1.0 / 32, 1e-15);
  EXPECT_NEAR(small.shape_integral_um2(0), 5.0 / 192, 1e-15);
  EXPECT_NEAR(small.shape_integral_um2(1), 1.0 / 384, 1e-15);
  EXPECT_NEAR(small.shape_integral_um2(2), 1.0 / 384, 1e-15);
  // The other side is the quadrilateral: the whole triangle's A/3 = 1/6 each, less the tip.
  const ClippedTriangle quad = clip_triangle(a, b, c, 0.5, -1);
  EXPECT_NEAR(quad.area_um2, 0.5 - 1.0 / 8, 1e-15);
  EXPECT_NEAR(quad.shape_integral_um2(0), 1.0 / 6 - 1.0 / 12, 1e-15);
  EXPECT_NEAR(quad.shape_integral_um2(1), 1.0 / 6 - 1.0 / 48, 1e-15);
  // Wholly on one side, and a plane through a vertex.
  EXPECT_NEAR(clip_triangle(a, b, c, -1.0, 1).shape_integral_um2(1), 1.0 / 6, 1e-15);
  EXPECT_EQ(clip_triangle(a, b, c, 2.0, 1).area_um2, 0.0);
  EXPECT_NEAR(clip_triangle(a, b, c, 0.0, 1).area_um2, 0.5, 1e-15);
  EXPECT_THROW(clip_triangle(a, b, c, 0.5, 0), std::invalid_argument);
}

TEST(ContactLoad, PrescribedTotalForceAndAreaOnIrregularMeshes) {
  for (int frequency : {3, 5, 8, 13})
    for (unsigned seed : {1u, 2u, 3u})
      for (double fraction : {0.02, 0.05, 0.2}) {
        const TriMesh m = irregular_mesh(frequency, seed);
        const ContactLoad load = exact_contact_load(m.x, m.topo, fraction);
        const double target = fraction * total_area(m.x, m.topo);
        SCOPED_TRACE("frequency " + std::to_string(frequency) + " seed " + std::to_string(seed) +
                     " fraction " + std::to_string(fraction));
        EXPECT_NEAR(side_sum(load.patch, 1), 1.0, 1e-14);
        EXPECT_NEAR(side_sum(load.patch, -1), -1.0, 1e-14);
        EXPECT_NEAR(load.patch.area_plus_um2, target, 1e-12 * target);
        EXPECT_NEAR(load.patch.area_minus_um2, target, 1e-12 * target);
        // The force the tweezers potential applies: the gradient's x components, +F on the
        // +x side and -F on the other, F to round-off.
        const double force_pN = 193.0;
        Positions grad = Positions::Zero(3, m.x.cols());
        tweezers_energy(load.patch, force_pN, m.x, m.x, &grad);
        const Eigen::VectorXd plus = dense_shares(load.patch, m.topo.num_vertices, 1);
        double applied = 0;
        for (int i = 0; i < m.topo.num_vertices; ++i)
          if (plus(i) > 0) applied -= grad(0, i);
        EXPECT_NEAR(applied, force_pN, 1e-12 * force_pN);
      }
  // The Evans-Fung cell meshes the stretch uses, in random orientations.
  for (unsigned seed : {0u, 11u, 12u}) {
    const TriMesh m = make_continuum_mesh(500, seed);
    const ContactLoad load = exact_contact_load(m.x, m.topo, 0.05);
    EXPECT_NEAR(side_sum(load.patch, 1), 1.0, 1e-14);
    EXPECT_NEAR(load.patch.area_plus_um2, 0.05 * total_area(m.x, m.topo), 1e-11);
  }
}

TEST(ContactLoad, ChangesContinuouslyWhenThePlaneOrTheMeshMoves) {
  const TriMesh m = irregular_mesh(8, 4);
  const int n = m.topo.num_vertices;
  const double h = mean_edge(m);
  // The plane through a vertex of the cap's edge: the vertex patch would take or drop that
  // vertex whole here.
  const ContactLoad base = exact_contact_load(m.x, m.topo, 0.05);
  Eigen::Index near = 0;
  (m.x.row(0).array() - base.plane_plus_um).abs().minCoeff(&near);
  const double plane = m.x(0, near);
  const Eigen::VectorXd at =
      dense_shares(contact_load_at(m.x, m.topo, plane, base.plane_minus_um).patch, n, 1);
  double change[2];
  for (int k = 0; k < 2; ++k) {
    const double delta = (k == 0 ? 1e-5 : 1e-6) * h;
    const Eigen::VectorXd above =
        dense_shares(contact_load_at(m.x, m.topo, plane + delta, base.plane_minus_um).patch, n, 1);
    const Eigen::VectorXd below =
        dense_shares(contact_load_at(m.x, m.topo, plane - delta, base.plane_minus_um).patch, n, 1);
    change[k] = std::max((above - at).cwiseAbs().maxCoeff(), (below - at).cwiseAbs().maxCoeff());
  }
  // Lipschitz: the change scales with the shift (ratio 10), of size (shift / h) x share.
  EXPECT_LT(change[0], 1e-3);
  EXPECT_NEAR(change[0] / change[1], 10.0, 0.5);
  // Moving the mesh by 1e-6 h moves the load by O(1e-6).
  TriMesh moved = m;
  testing::perturb(moved.x, 1e-6 * h, 99);
  const Eigen::VectorXd shifted =
      dense_shares(contact_load_at(moved.x, moved.topo, plane, base.plane_minus_um).patch, n, 1);
  EXPECT_LT((shifted - at).cwiseAbs().maxCoeff(), 1e-4);
  // The vertex patch, for comparison, jumps by a whole vertex's share when the target area
  // crosses that vertex: at least 1 / (patch vertices) / 2 somewhere.
  TweezersParameters lo, hi;
  lo.contact_fraction = 0.05;
  hi.contact_fraction = 0.05;
  double jump = 0;
  for (double f = 0.045; f < 0.055; f += 2e-4) {
    lo.contact_fraction = f;
    hi.contact_fraction = f + 2e-4;
    const Eigen::VectorXd a = dense_shares(select_tweezer_patch(m.x, m.topo, lo), n, 1);
    const Eigen::VectorXd b = dense_shares(select_tweezer_patch(m.x, m.topo, hi), n, 1);
    jump = std::max(jump, (a - b).cwiseAbs().maxCoeff());
  }
  const ContactLoad l0 = exact_contact_load(m.x, m.topo, 0.045);
  EXPECT_GT(jump, 0.5 / static_cast<double>(l0.patch.vertex.size()));
}

TEST(ContactLoad, WholeElementRegionGivesTheLumpedVertexLoad) {
  // A degree-5 vertex of an icosphere turned onto +x: its five neighbours lie in one plane
  // x = c (the 5-fold symmetry), so the cap x >= c is exactly the fan of five equal triangles.
  // A uniform traction on whole linear elements has the lumped (vertex-area) nodal forces:
  // A_f/3 from each element, i.e. the pole 5 (A_f/3) / (5 A_f) = 1/3 and each rim vertex
  // 2 (A_f/3) / (5 A_f) = 2/15 -- the by-area vertex patch's rule with vertex areas taken over
  // the region's elements.
  TriMesh m = make_icosphere(3);
  int pole = -1;
  for (int v = 0; v < m.topo.num_vertices && pole < 0; ++v)
    if (m.topo.vertex_neighbours.size(v) == 5) pole = v;
  ASSERT_GE(pole, 0);
  const Eigen::Matrix3d r =
      Eigen::Quaterniond::FromTwoVectors(m.x.col(pole).normalized(), Vec3::UnitX())
          .toRotationMatrix();
  m.x = r * m.x;
  double ring_x = 2.0;
  for (const int* a = m.topo.vertex_neighbours.begin(pole); a != m.topo.vertex_neighbours.end(pole);
       ++a)
    ring_x = std::min(ring_x, m.x(0, *a));
  const ContactLoad load = contact_load_at(m.x, m.topo, ring_x, -ring_x);
  const Eigen::VectorXd s = dense_shares(load.patch, m.topo.num_vertices, 1);
  EXPECT_NEAR(s(pole), 1.0 / 3.0, 1e-12);
  for (const int* a = m.topo.vertex_neighbours.begin(pole); a != m.topo.vertex_neighbours.end(pole);
       ++a)
    EXPECT_NEAR(s(*a), 2.0 / 15.0, 1e-12);
  EXPECT_NEAR(s.sum(), 1.0, 1e-14);
  // And the limit from a plane just inside the fan is the same load (continuity).
  const double h = mean_edge(m);
  const Eigen::VectorXd inside = dense_shares(
      contact_load_at(m.x, m.topo, ring_x + 1e-9 * h, -ring_x).patch, m.topo.num_vertices, 1);
  EXPECT_LT((inside - s).cwiseAbs().maxCoeff(), 1e-6);
}

/// Centroid moment integral_{X_x >= plane} X dA of the mesh, by clipping each triangle in
/// Cartesian coordinates (edge-plane intersections) and summing area-weighted centroids of the
/// clipped polygon's fan: independent of the barycentric quadrature under test.
Vec3 cartesian_cap_moment(const TriMesh& m, double plane, double& area) {
  Vec3 moment = Vec3::Zero();
  area = 0;
  for (int f = 0; f < m.topo.num_faces(); ++f) {
    std::vector<Vec3> poly;
    for (int i = 0; i < 3; ++i) {
      const Vec3 p = m.x.col(m.topo.faces(i, f)), q = m.x.col(m.topo.faces((i + 1) % 3, f));
      if (p.x() >= plane) poly.push_back(p);
      if ((p.x() - plane) * (q.x() - plane) < 0)
        poly.push_back(p + (plane - p.x()) / (q.x() - p.x()) * (q - p));
    }
    for (size_t k = 1; k + 1 < poly.size(); ++k) {
      const double a = 0.5 * (poly[k] - poly[0]).cross(poly[k + 1] - poly[0]).norm();
      area += a;
      moment += a * (poly[0] + poly[k] + poly[k + 1]) / 3.0;
    }
  }
  return moment;
}

TEST(ContactLoad, FirstMomentIsTheClippedRegionsCentroid) {
  for (int frequency : {4, 9})
    for (unsigned seed : {5u, 6u}) {
      const TriMesh m = irregular_mesh(frequency, seed);
      const ContactLoad load = exact_contact_load(m.x, m.topo, 0.05);
      const Eigen::VectorXd s = dense_shares(load.patch, m.topo.num_vertices, 1);
      const Vec3 applied = m.x * s;  // sum_i share_i X_i: the point of application
      double area = 0;
      const Vec3 centroid = cartesian_cap_moment(m, load.plane_plus_um, area) / area;
      EXPECT_NEAR(area, load.patch.area_plus_um2, 1e-12 * area);
      EXPECT_LT((applied - centroid).norm(), 1e-12)
          << applied.transpose() << " vs " << centroid.transpose();
      EXPECT_GT(applied.x(), load.plane_plus_um);
    }
}

TEST(ContactLoad, KeepsEveryMirrorOfTheMesh) {
  // The caps are bounded by planes x = c+-, which every mirror of the mesh that fixes x keeps,
  // and x -> -x swaps them (c- = -c+ on an x-symmetric mesh), so the load keeps the mesh's
  // whole mirror group; the vertex patch cuts mirror pairs apart on some meshes.
  for (int elements : {500, 1000, 8000}) {
    const TriMesh m = make_continuum_mesh(elements);
    const int mesh_order = find_mirror_symmetry(m.x, m.topo).order();
    const ContactLoad load = exact_contact_load(m.x, m.topo, 0.05);
    EXPECT_EQ(tweezers_scene_symmetry(m.x, m.topo, load.patch).order(), mesh_order)
        << elements << " elements";
    EXPECT_GE(mesh_order, 4);
  }
}

TEST(ContactLoad, RefusesBadInput) {
  const TriMesh m = irregular_mesh(3, 1);
  EXPECT_THROW(exact_contact_load(m.x, m.topo, 0.0), InvalidParameter);
  EXPECT_THROW(exact_contact_load(m.x, m.topo, 0.5), InvalidParameter);
  EXPECT_THROW(exact_contact_load(m.x, m.topo, std::nan("")), InvalidParameter);
  EXPECT_THROW(contact_load_at(m.x, m.topo, 100.0, -1.0), std::invalid_argument);
  EXPECT_THROW(cap_plane_for_area(m.x, m.topo, -1.0, 1), std::invalid_argument);
  ContinuumOptions o;
  o.exact_contact_fraction = 0.7;
  EXPECT_THROW(o.validate(), InvalidParameter);
}

TEST(ContactLoad, StretchOptionsKeepTheDefaultAndOfferTheExactLoadAndFittedMeasure) {
  const ContinuumModel model = build_continuum_model(
      make_continuum_mesh(2000),
      make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::full), {});
  const std::vector<double> forces = {193.0};
  ContinuumOptions base;
  base.element_fields = false;
  EXPECT_EQ(base.load, ContinuumLoad::vertex_patch);
  EXPECT_EQ(base.measure, ContinuumMeasure::vertices);
  const auto vertex = run_continuum_stretch(model, forces, base);
  ContinuumOptions exact = base;
  exact.load = ContinuumLoad::exact_contact;
  exact.measure = ContinuumMeasure::quadric_fit;
  const auto fitted = run_continuum_stretch(model, forces, exact);
  ASSERT_TRUE(vertex[0].converged);
  ASSERT_TRUE(fitted[0].converged);
  // The default measures the vertices; the option the fitted surface.
  const Diameters dv = measure_diameters(vertex[0].x);
  EXPECT_EQ(vertex[0].axial_um, dv.axial_um);
  EXPECT_EQ(vertex[0].transverse_um, dv.transverse_um);
  const Diameters df = surface_diameters(fitted[0].x, model.topo);
  EXPECT_EQ(fitted[0].axial_um, df.axial_um);
  EXPECT_EQ(fitted[0].transverse_um, df.transverse_um);
  // The exact load is another resolution of the same 5 % caps: the equilibria agree to the
  // discretisation error (measured on the vertices: 0.06 %), while their loads differ.
  const Diameters fv = measure_diameters(fitted[0].x);
  EXPECT_NEAR(fv.axial_um, dv.axial_um, 0.01 * dv.axial_um);
  EXPECT_NEAR(fv.transverse_um, dv.transverse_um, 0.01 * dv.transverse_um);
  EXPECT_GT((fitted[0].x - vertex[0].x).cwiseAbs().maxCoeff(), 1e-3);
  const Diameters vf = surface_diameters(vertex[0].x, model.topo);
  std::cout << "193 pN, " << model.num_elements() << " elements (full law): D_A, D_T (um)\n"
            << "  vertex patch,  vertices:    " << dv.axial_um << ", " << dv.transverse_um << "\n"
            << "  vertex patch,  quadric fit: " << vf.axial_um << ", " << vf.transverse_um << "\n"
            << "  exact contact, vertices:    " << fv.axial_um << ", " << fv.transverse_um << "\n"
            << "  exact contact, quadric fit: " << df.axial_um << ", " << df.transverse_um << "\n";
}

}  // namespace
}  // namespace contact_load_test
}  // namespace rbc
