// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "core/parallel.hpp"

namespace rbc {

// Deterministic chunked sums (core/parallel.hpp): the same bits with any thread count.
double total_area(const Positions& x, const Topology& topo) {
  return sum_parallel(topo.num_faces(), [&](int f) {
    const auto& t = topo.faces.col(f);
    return triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  });
}

double enclosed_volume(const Positions& x, const Topology& topo) {
  return sum_parallel(topo.num_faces(), [&](int f) {
    const auto& t = topo.faces.col(f);
    return tetra_volume(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  });
}

Eigen::VectorXd face_areas(const Positions& x, const Topology& topo) {
  Eigen::VectorXd a(topo.num_faces());
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto& t = topo.faces.col(f);
    a(f) = triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  }
  return a;
}

Eigen::VectorXd vertex_areas(const Positions& x, const Topology& topo) {
  const Eigen::VectorXd af = face_areas(x, topo);
  Eigen::VectorXd a = Eigen::VectorXd::Zero(topo.num_vertices);
  for (int f = 0; f < topo.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) a(topo.faces(k, f)) += af(f) / 3.0;
  return a;
}

Eigen::VectorXd edge_lengths(const Positions& x, const Topology& topo) {
  Eigen::VectorXd l(topo.num_edges());
  for (int e = 0; e < topo.num_edges(); ++e)
    l(e) = edge_length(x.col(topo.edges(0, e)), x.col(topo.edges(1, e)));
  return l;
}

Diameters measure_diameters(const Positions& x) {
  Diameters d;
  if (x.cols() == 0) return d;
  d.axial_um = x.row(0).maxCoeff() - x.row(0).minCoeff();
  // The largest extent over directions u in the y-z plane, max_u (max u.p - min u.p), is the
  // largest distance between two projected points p = (y, z): the diameter of their convex
  // hull (Andrew's monotone chain), found over pairs of hull vertices. Exact, where a scan of
  // directions is not; O(N log N).
  // Akl-Toussaint: the points extreme along y, y + z, z, z - y and their opposites span a convex
  // octagon inside the hull, so a point strictly inside it is no hull vertex and is dropped
  // before the sort (the hull, and so the result, are the same).
  const Eigen::Index n = x.cols();
  Eigen::Index ext[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  auto along = [&](int k, Eigen::Index i) {  // direction k * 45 degrees from +y
    static constexpr double c[8] = {1, 1, 0, -1, -1, -1, 0, 1}, d[8] = {0, 1, 1, 1, 0, -1, -1, -1};
    return c[k] * x(1, i) + d[k] * x(2, i);
  };
  for (Eigen::Index i = 1; i < n; ++i)
    for (int k = 0; k < 8; ++k)
      if (along(k, i) > along(k, ext[k])) ext[k] = i;
  std::vector<std::pair<double, double>> p;
  p.reserve(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    bool inside = true;
    int edges = 0;
    for (int k = 0; k < 8 && inside; ++k) {
      const Eigen::Index a = ext[k], b = ext[(k + 1) % 8];
      if (x(1, a) == x(1, b) && x(2, a) == x(2, b)) continue;  // a degenerate edge
      ++edges;
      inside =
          (x(1, b) - x(1, a)) * (x(2, i) - x(2, a)) - (x(2, b) - x(2, a)) * (x(1, i) - x(1, a)) >
          0.0;
    }
    if (!inside || edges < 3) p.emplace_back(x(1, i), x(2, i));
  }
  std::sort(p.begin(), p.end());
  p.erase(std::unique(p.begin(), p.end()), p.end());
  auto cross = [](const std::pair<double, double>& o, const std::pair<double, double>& a,
                  const std::pair<double, double>& b) {
    return (a.first - o.first) * (b.second - o.second) -
           (a.second - o.second) * (b.first - o.first);
  };
  std::vector<std::pair<double, double>> hull(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {  // lower hull
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i-- > 0;) {  // upper hull
    while (k >= t && cross(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  hull.resize(k > 1 ? k - 1 : k);
  double best2 = 0.0;
  for (size_t i = 0; i < hull.size(); ++i)
    for (size_t j = i + 1; j < hull.size(); ++j) {
      const double dy = hull[i].first - hull[j].first, dz = hull[i].second - hull[j].second;
      best2 = std::max(best2, dy * dy + dz * dz);
    }
  d.transverse_um = std::sqrt(best2);
  return d;
}

double triangle_aspect_ratio(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double area = triangle_area(a, b, c);
  const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  const double shortest_altitude = 2.0 * area / longest;
  return longest * 0.86602540378443864676 / shortest_altitude;
}

}  // namespace rbc
