#include "core/geometry.hpp"

#include <algorithm>

namespace rbc {

double total_area(const Positions& x, const Topology& topo) {
  double area = 0.0;
#pragma omp parallel for reduction(+ : area) schedule(static)
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto& t = topo.faces.col(f);
    area += triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  }
  return area;
}

double enclosed_volume(const Positions& x, const Topology& topo) {
  double volume = 0.0;
#pragma omp parallel for reduction(+ : volume) schedule(static)
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto& t = topo.faces.col(f);
    volume += tetra_volume(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  }
  return volume;
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
  d.transverse_um = x.row(1).maxCoeff() - x.row(1).minCoeff();
  return d;
}

double triangle_aspect_ratio(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double area = triangle_area(a, b, c);
  const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  const double shortest_altitude = 2.0 * area / longest;
  return longest * 0.86602540378443864676 / shortest_altitude;
}

}  // namespace rbc
