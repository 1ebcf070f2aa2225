#include "core/geometry.hpp"

#include <algorithm>
#include <cmath>

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
  d.axial_um = x.row(0).maxCoeff() - x.row(0).minCoeff();
  // Extent along (0, cos phi, sin phi): scan phi in [0, pi) by 2 degrees, then refine the
  // best bracket by golden-section search (the width is smooth near its maximum).
  auto extent = [&](double phi) {
    const Eigen::RowVectorXd p = std::cos(phi) * x.row(1) + std::sin(phi) * x.row(2);
    return p.maxCoeff() - p.minCoeff();
  };
  constexpr int kScan = 90;
  const double step = 3.14159265358979323846 / kScan;
  int best = 0;
  double best_width = -1.0;
  for (int k = 0; k < kScan; ++k) {
    const double w = extent(k * step);
    if (w > best_width) {
      best_width = w;
      best = k;
    }
  }
  double lo = (best - 1) * step, hi = (best + 1) * step;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double m1 = hi - g * (hi - lo), m2 = lo + g * (hi - lo);
  double w1 = extent(m1), w2 = extent(m2);
  for (int it = 0; it < 30; ++it) {
    if (w1 > w2) {
      hi = m2;
      m2 = m1;
      w2 = w1;
      m1 = hi - g * (hi - lo);
      w1 = extent(m1);
    } else {
      lo = m1;
      m1 = m2;
      w1 = w2;
      m2 = lo + g * (hi - lo);
      w2 = extent(m2);
    }
  }
  d.transverse_um = std::max({best_width, w1, w2});
  return d;
}

double triangle_aspect_ratio(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double area = triangle_area(a, b, c);
  const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  const double shortest_altitude = 2.0 * area / longest;
  return longest * 0.86602540378443864676 / shortest_altitude;
}

}  // namespace rbc
