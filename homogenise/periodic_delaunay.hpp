// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Periodic 2D Delaunay triangulation of a point set on a square torus. The only door to
// CGAL (Periodic_2_Delaunay_triangulation_2, CGAL 5.5): it stays in periodic_delaunay.cpp,
// callers see plain arrays.
#include <Eigen/Core>
#include <array>
#include <vector>

namespace rbc {

/// Triangles of the periodic triangulation, counter-clockwise, each corner a point index
/// and the periodic offset (in units of the side) of the copy of that point used, so the
/// triangle's corners are points[v[k]] + side * offset[k].
struct PeriodicTriangulation {
  std::vector<std::array<int, 3>> triangles;
  std::vector<std::array<std::array<int, 2>, 3>> offsets;
};

/// points: 2 x N (um) in [0, side)^2. Throws std::invalid_argument for points outside the
/// square or duplicates, and when the Delaunay triangulation is not a simplicial complex on
/// the torus (too few points for the square: CGAL then stays in its 9-sheeted covering).
PeriodicTriangulation periodic_delaunay(const Eigen::Matrix2Xd& points, double side_um);

}  // namespace rbc
