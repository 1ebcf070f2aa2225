// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/contact_load.hpp"

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/validation.hpp"

namespace rbc {

ClippedTriangle clip_triangle(const Vec3& x0, const Vec3& x1, const Vec3& x2, double plane_x_um,
                              int side) {
  if (side != 1 && side != -1)
    throw std::invalid_argument("clip_triangle: side must be +1 or -1, got " +
                                std::to_string(side));
  const std::array<double, 3> d = {side * (x0.x() - plane_x_um), side * (x1.x() - plane_x_um),
                                   side * (x2.x() - plane_x_um)};
  ClippedTriangle out;
  if (d[0] < 0 && d[1] < 0 && d[2] < 0) return out;
  const double area = triangle_area(x0, x1, x2);
  if (d[0] >= 0 && d[1] >= 0 && d[2] >= 0) {
    out.area_um2 = area;
    out.shape_integral_um2.setConstant(area / 3.0);
    return out;
  }
  // Sutherland-Hodgman against d >= 0, polygon vertices in barycentric coordinates: at most
  // four (a triangle cut by a plane leaves a triangle or a quadrilateral).
  std::array<Vec3, 4> poly;
  int m = 0;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    if (d[i] >= 0) poly[m++] = Vec3::Unit(i);
    if ((d[i] < 0 && d[j] > 0) || (d[i] > 0 && d[j] < 0)) {
      const double t = d[i] / (d[i] - d[j]);
      poly[m++] = (1.0 - t) * Vec3::Unit(i) + t * Vec3::Unit(j);
    }
  }
  // Fan from poly[0]: a sub-triangle's area is the triangle's times the determinant of its
  // corners' barycentric coordinates (>= 0: clipping keeps the orientation).
  for (int k = 1; k + 1 < m; ++k) {
    Eigen::Matrix3d b;
    b << poly[0], poly[k], poly[k + 1];
    const double a = area * b.determinant();
    out.area_um2 += a;
    out.shape_integral_um2 += a * (poly[0] + poly[k] + poly[k + 1]) / 3.0;
  }
  return out;
}

double cap_area(const Positions& x, const Topology& topo, double plane_x_um, int side) {
  double a = 0.0;
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto t = topo.faces.col(f);
    a += clip_triangle(x.col(t(0)), x.col(t(1)), x.col(t(2)), plane_x_um, side).area_um2;
  }
  return a;
}

double cap_plane_for_area(const Positions& x, const Topology& topo, double area_um2, int side) {
  const double total = total_area(x, topo);
  if (!(area_um2 > 0 && area_um2 < total))
    throw std::invalid_argument("cap area " + std::to_string(area_um2) +
                                " um^2 is outside (0, total area " + std::to_string(total) + ")");
  if (side != 1 && side != -1)
    throw std::invalid_argument("cap_plane_for_area: side must be +1 or -1, got " +
                                std::to_string(side));
  // The cap area falls from the total to 0 as the plane moves towards the bead's end.
  double inner = side > 0 ? x.row(0).minCoeff() : x.row(0).maxCoeff();
  double outer = side > 0 ? x.row(0).maxCoeff() : x.row(0).minCoeff();
  for (int it = 0; it < 2000; ++it) {
    const double mid = 0.5 * (inner + outer);
    if (mid == inner || mid == outer) break;
    (cap_area(x, topo, mid, side) > area_um2 ? inner : outer) = mid;
  }
  return 0.5 * (inner + outer);
}

ContactLoad contact_load_at(const Positions& rest, const Topology& topo, double plane_plus_um,
                            double plane_minus_um) {
  ContactLoad out;
  out.plane_plus_um = plane_plus_um;
  out.plane_minus_um = plane_minus_um;
  const int n = topo.num_vertices;
  for (int side : {1, -1}) {
    Eigen::VectorXd integral = Eigen::VectorXd::Zero(n);
    const double plane = side > 0 ? plane_plus_um : plane_minus_um;
    for (int f = 0; f < topo.num_faces(); ++f) {
      const auto t = topo.faces.col(f);
      const ClippedTriangle c =
          clip_triangle(rest.col(t(0)), rest.col(t(1)), rest.col(t(2)), plane, side);
      if (c.area_um2 == 0.0) continue;
      for (int k = 0; k < 3; ++k) integral(t(k)) += c.shape_integral_um2(k);
    }
    // The cap's area as the sum of what is distributed, so each side's shares sum to 1 to
    // round-off.
    const double area = integral.sum();
    if (!(area > 0))
      throw std::invalid_argument("contact region x " + std::string(side > 0 ? ">= " : "<= ") +
                                  std::to_string(plane) + " um is empty");
    for (int i = 0; i < n; ++i)
      if (integral(i) > 0) {
        out.patch.vertex.push_back(i);
        out.patch.share.push_back(side * integral(i) / area);
      }
    (side > 0 ? out.patch.area_plus_um2 : out.patch.area_minus_um2) = area;
  }
  return out;
}

ContactLoad exact_contact_load(const Positions& rest, const Topology& topo,
                               double contact_fraction) {
  require_finite_in_range("bead contact fraction", "", contact_fraction, 0.0, 0.5, Ends::open_open);
  const double target = contact_fraction * total_area(rest, topo);
  return contact_load_at(rest, topo, cap_plane_for_area(rest, topo, target, 1),
                         cap_plane_for_area(rest, topo, target, -1));
}

}  // namespace rbc
