// SPDX-License-Identifier: GPL-3.0-or-later
// Graded meshes that keep their connectivity (continuum/surface_grading.hpp): vertices on the
// surface, valences and faces unchanged, edges fine where the size field is small, the scene's
// mirror symmetry kept, bad options refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "continuum/continuum_model.hpp"
#include "continuum/surface_grading.hpp"
#include "core/validation.hpp"

namespace rbc {
namespace {

TEST(SurfaceGrading, EdgesFollowTheSizeFieldOnTheSurfaceWithTheConnectivityAndMirrorKept) {
  const EvansFungShape shape;
  // The orientation that keeps the scene's three mirror planes (core/rest_shape.hpp).
  const TriMesh m = make_continuum_mesh(2000, 0, TriangulationOrientation::mirror_planes);
  SceneSizeField field;
  field.plane_um = rest_contact_plane(shape, 0.05);
  field.fine_um = 1.0;
  field.coarse_um = 3.0;
  const TriMesh g = grade_on_evans_fung_surface(m, shape, field);
  EXPECT_EQ(g.topo.faces, m.topo.faces);
  double off = 0;
  for (int i = 0; i < g.x.cols(); ++i)
    off = std::max(off, (evans_fung_project(shape, g.x.col(i)) - g.x.col(i)).norm());
  EXPECT_LT(off, 1e-12);
  // Mean edge length in the fine caps against the coarse middle, before and after.
  auto ratio = [&](const TriMesh& t) {
    const double start = field.plane_um - field.band_um;
    const double fine = mean_edge_length(t, [&](const Vec3& c) { return std::abs(c.x()) > start; });
    const double coarse = mean_edge_length(t, [&](const Vec3& c) { return std::abs(c.x()) < 1.0; });
    return coarse / fine;
  };
  std::printf("coarse / fine mean edge length: %.2f before, %.2f after (field ratio 3)\n", ratio(m),
              ratio(g));
  EXPECT_GT(ratio(g), 1.7 * ratio(m));
  // Each coordinate mirror of the rest mesh (x_k -> -x_k maps vertices onto vertices) that the
  // size field shares (x and z: the field depends on |x| only) is a mirror of the graded mesh,
  // vertex for vertex.
  int mirrors = 0;
  for (int axis : {0, 2}) {
    auto image = [&](const Positions& x, int i) {
      Vec3 p = x.col(i);
      p(axis) = -p(axis);
      return p;
    };
    double rest_worst = 0, graded_worst = 0;
    for (int i = 0; i < m.x.cols(); ++i) {
      int j = 0;
      for (int k = 1; k < m.x.cols(); ++k)
        if ((m.x.col(k) - image(m.x, i)).norm() < (m.x.col(j) - image(m.x, i)).norm()) j = k;
      rest_worst = std::max(rest_worst, (m.x.col(j) - image(m.x, i)).norm());
      graded_worst = std::max(graded_worst, (g.x.col(j) - image(g.x, i)).norm());
    }
    std::printf("mirror of axis %d: rest mesh %.1e um, graded %.1e um\n", axis, rest_worst,
                graded_worst);
    if (rest_worst > 1e-9) continue;
    ++mirrors;
    EXPECT_LT(graded_worst, 1e-9) << "mirror of axis " << axis;
  }
  EXPECT_GE(mirrors, 1);
}

TEST(SurfaceGrading, BadOptionsAreRefused) {
  const EvansFungShape shape;
  const TriMesh m = make_continuum_mesh(500, shape);
  SurfaceGradingOptions o;
  o.sweeps = 0;
  EXPECT_THROW(grade_on_evans_fung_surface(m, shape, SceneSizeField{}, o), InvalidParameter);
  o = {};
  o.relaxation = 1.5;
  EXPECT_THROW(grade_on_evans_fung_surface(m, shape, SceneSizeField{}, o), InvalidParameter);
}

}  // namespace
}  // namespace rbc
