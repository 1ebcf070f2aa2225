// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/surface_extent.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace rbc {

namespace {

/// The vertex and its neighbours up to `depth` edges away, sorted.
std::vector<int> ring(const Topology& topo, int v, int depth) {
  std::vector<int> out = {v};
  size_t from = 0;
  for (int d = 0; d < depth; ++d) {
    const size_t to = out.size();
    for (size_t k = from; k < to; ++k)
      for (const int* a = topo.vertex_neighbours.begin(out[k]);
           a != topo.vertex_neighbours.end(out[k]); ++a)
        out.push_back(*a);
    from = to;
    std::sort(out.begin() + static_cast<std::ptrdiff_t>(to), out.end());
    out.erase(std::unique(out.begin() + static_cast<std::ptrdiff_t>(to), out.end()), out.end());
    // Drop what an earlier ring already holds.
    std::vector<int> seen(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(to));
    std::sort(seen.begin(), seen.end());
    out.erase(
        std::remove_if(out.begin() + static_cast<std::ptrdiff_t>(to), out.end(),
                       [&](int w) { return std::binary_search(seen.begin(), seen.end(), w); }),
        out.end());
  }
  return out;
}

/// The quadric through the origin fitted to the heights h over (a, b) (scaled by the
/// stencil radius); false if the system is rank deficient.
bool fit_quadric(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const Eigen::VectorXd& h,
                 double radius, Eigen::Matrix<double, 5, 1>& c) {
  const Eigen::Index m = a.size();
  if (m < 5) return false;
  Eigen::MatrixXd design(m, 5);
  for (Eigen::Index k = 0; k < m; ++k) {
    const double p = a(k) / radius, q = b(k) / radius;
    design.row(k) << p, q, p * p, p * q, q * q;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(design);
  if (qr.rank() < 5) return false;
  c = qr.solve(h);
  return true;
}

}  // namespace

SurfaceSupport surface_support(const Positions& x, const Topology& topo, const Vec3& u_in) {
  const Vec3 u = u_in.normalized();
  SurfaceSupport s;
  if (x.cols() == 0) return s;
  Eigen::Index v = 0;
  (u.transpose() * x).maxCoeff(&v);
  s.vertex = static_cast<int>(v);
  s.point = x.col(v);
  s.value_um = u.dot(s.point);
  // Frame (e1, e2, u) at x_v.
  const Vec3 helper = std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 e1 = u.cross(helper).normalized(), e2 = u.cross(e1);
  // The 1-ring (the 2-ring where the 1-ring leaves the fit undetermined), the vertex itself
  // fixed at the origin.
  Eigen::Matrix<double, 5, 1> c;
  double radius = 0.0;
  bool ok = false;
  for (int depth = 1; depth <= 2 && !ok; ++depth) {
    const std::vector<int> stencil = ring(topo, s.vertex, depth);
    const Eigen::Index m = static_cast<Eigen::Index>(stencil.size()) - 1;
    Eigen::VectorXd a(m), b(m), h(m);
    radius = 0.0;
    for (Eigen::Index k = 0; k < m; ++k) {
      const Vec3 d = x.col(stencil[static_cast<size_t>(k + 1)]) - s.point;
      a(k) = e1.dot(d);
      b(k) = e2.dot(d);
      h(k) = u.dot(d);
      radius = std::max(radius, std::hypot(a(k), b(k)));
    }
    ok = radius > 0 && fit_quadric(a, b, h, radius, c);
  }
  if (!ok) return s;
  // Stationary point of the quadric (scaled coordinates): H z = -g.
  Eigen::Matrix2d hess;
  hess << 2 * c(2), c(3), c(3), 2 * c(4);
  const Eigen::Vector2d g(c(0), c(1));
  if (!(hess.determinant() > 0 && hess(0, 0) < 0)) return s;  // no maximum
  const Eigen::Vector2d z = hess.ldlt().solve(-g);
  if (!(z.norm() <= 1.0)) return s;   // outside the stencil: the fit does not know it
  const double top = 0.5 * g.dot(z);  // value of the quadric at its stationary point (>= 0)
  s.fitted = true;
  s.value_um += top;
  s.point += radius * (z(0) * e1 + z(1) * e2) + top * u;
  return s;
}

Diameters surface_diameters(const Positions& x, const Topology& topo) {
  Diameters d;
  if (x.cols() == 0) return d;
  auto width = [&](const Vec3& u) {
    return surface_support(x, topo, u).value_um + surface_support(x, topo, -u).value_um;
  };
  d.axial_um = width(Vec3::UnitX());
  // The widest direction of the vertices over a scan of directions in the y-z plane starts
  // the search.
  auto dir = [](double theta) { return Vec3(0.0, std::cos(theta), std::sin(theta)); };
  constexpr int kScan = 180;  // directions over a half-turn (widths are pi-periodic)
  double best = -1.0, theta0 = 0.0;
  for (int k = 0; k < kScan; ++k) {
    const double th = M_PI * k / kScan;
    const Vec3 u = dir(th);
    const Eigen::RowVectorXd p = u.transpose() * x;
    const double w = p.maxCoeff() - p.minCoeff();
    if (w > best) {
      best = w;
      theta0 = th;
    }
  }
  // Golden-section search for the widest direction of the fitted surface about it: the vertex
  // widths scatter by O(h^2) about the smooth width, which is flat at its maximum, so their
  // widest direction may be a few degrees off; the bracket is +-kBracket_rad.
  constexpr double kBracket_rad = 0.25;
  const double invphi = 0.5 * (std::sqrt(5.0) - 1.0);
  double lo = theta0 - kBracket_rad, hi = theta0 + kBracket_rad;
  double t1 = hi - invphi * (hi - lo), t2 = lo + invphi * (hi - lo);
  double w1 = width(dir(t1)), w2 = width(dir(t2));
  while (hi - lo > 1e-9) {
    if (w1 > w2) {
      hi = t2;
      t2 = t1;
      w2 = w1;
      t1 = hi - invphi * (hi - lo);
      w1 = width(dir(t1));
    } else {
      lo = t1;
      t1 = t2;
      w1 = w2;
      t2 = lo + invphi * (hi - lo);
      w2 = width(dir(t2));
    }
  }
  d.transverse_um = std::max({w1, w2, width(dir(theta0))});
  return d;
}

}  // namespace rbc
