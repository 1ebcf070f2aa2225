// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/periodic_delaunay.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Periodic_2_Delaunay_triangulation_2.h>
#include <CGAL/Periodic_2_Delaunay_triangulation_traits_2.h>
#include <CGAL/Periodic_2_triangulation_face_base_2.h>
#include <CGAL/Periodic_2_triangulation_vertex_base_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <stdexcept>
#include <string>

namespace rbc {
namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Traits = CGAL::Periodic_2_Delaunay_triangulation_traits_2<Kernel>;
using VbBase = CGAL::Periodic_2_triangulation_vertex_base_2<Traits>;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, Traits, VbBase>;
using Fb = CGAL::Periodic_2_triangulation_face_base_2<Traits>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Triangulation = CGAL::Periodic_2_Delaunay_triangulation_2<Traits, Tds>;
}  // namespace

PeriodicTriangulation periodic_delaunay(const Eigen::Matrix2Xd& points, double side) {
  if (!(side > 0)) throw std::invalid_argument("periodic Delaunay: side must be positive");
  Triangulation T(Triangulation::Iso_rectangle(0, 0, side, side));
  for (int i = 0; i < points.cols(); ++i) {
    const double x = points(0, i), y = points(1, i);
    if (!(x >= 0 && x < side && y >= 0 && y < side))
      throw std::invalid_argument("periodic Delaunay: point " + std::to_string(i) +
                                  " lies outside the square [0, " + std::to_string(side) + ")^2");
    const auto before = T.number_of_vertices();
    auto vh = T.insert(Triangulation::Point(x, y));
    if (T.number_of_vertices() == before)
      throw std::invalid_argument("periodic Delaunay: point " + std::to_string(i) +
                                  " duplicates point " + std::to_string(vh->info()));
    vh->info() = i;
  }
  if (!T.is_1_cover())
    throw std::invalid_argument(
        "periodic Delaunay: " + std::to_string(points.cols()) +
        " points are too few for a triangulation of the torus in one sheet (use more cells)");
  PeriodicTriangulation out;
  for (auto f = T.faces_begin(); f != T.faces_end(); ++f) {
    const auto pt = T.periodic_triangle(f);
    std::array<int, 3> v{};
    std::array<std::array<int, 2>, 3> o{};
    for (int k = 0; k < 3; ++k) {
      v[k] = f->vertex(k)->info();
      o[k] = {pt[k].second.x(), pt[k].second.y()};
    }
    out.triangles.push_back(v);
    out.offsets.push_back(o);
  }
  return out;
}

}  // namespace rbc
