// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/disordered_network.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>

#include "core/units.hpp"
#include "core/validation.hpp"
#include "homogenise/periodic_delaunay.hpp"

namespace rbc {

void DisorderOptions::validate() const {
  require_integer_in_range("disordered network cells", cells, 4, 200);
  require_finite_in_range("disorder X", "", disorder, 0.0, 1.0, Ends::closed_closed);
  require_finite_in_range("disordered network spacing", "um", spacing_um, 0.0, 1.0);
  require_finite_in_range("disordered network jitter fraction", "", jitter_fraction, 0.0, 0.5,
                          Ends::closed_open);
}

int disordered_rows(int cells) {
  const double ideal = 2.0 * cells / units::sqrt3;
  return std::max(2, 2 * static_cast<int>(std::lround(ideal / 2.0)));
}

double disordered_row_distortion(int cells) {
  return (static_cast<double>(cells) / disordered_rows(cells)) / (0.5 * units::sqrt3) - 1.0;
}

PeriodicNetwork make_disordered_network(const DisorderOptions& o, unsigned seed) {
  o.validate();
  const int n = o.cells, m = disordered_rows(n);
  const double a = o.spacing_um, side = n * a, h = side / m;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double radius = o.disorder * o.jitter_fraction * a;
  Eigen::Matrix2Xd pts(2, n * m);
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      const double r = radius * std::sqrt(uni(rng)), t = 2.0 * units::pi * uni(rng);
      double x = (i + 0.5 * (j % 2)) * a + r * std::cos(t);
      double y = j * h + r * std::sin(t);
      x -= side * std::floor(x / side);
      y -= side * std::floor(y / side);
      pts.col(i + n * j) << (x < side ? x : 0.0), (y < side ? y : 0.0);
    }
  const PeriodicTriangulation tri = periodic_delaunay(pts, side);
  PeriodicNetwork net;
  net.box = side * Eigen::Matrix2d::Identity();
  net.points = pts;
  auto image = [&](int v, const std::array<int, 2>& off) -> Eigen::Vector2d {
    return pts.col(v) + side * Eigen::Vector2d(off[0], off[1]);
  };
  std::map<std::tuple<int, int, int, int>, bool> seen;
  for (std::size_t f = 0; f < tri.triangles.size(); ++f) {
    const auto& v = tri.triangles[f];
    const auto& off = tri.offsets[f];
    const Eigen::Vector2d p0 = image(v[0], off[0]), p1 = image(v[1], off[1]),
                          p2 = image(v[2], off[2]);
    PeriodicFace face{v, p1 - p0, p2 - p0, 0.0};
    face.abar_um2 = 0.5 * (face.e1.x() * face.e2.y() - face.e1.y() * face.e2.x());
    if (!(face.abar_um2 > 0))
      throw std::runtime_error("disordered network: Delaunay face with non-positive area");
    net.faces.push_back(face);
    for (int k = 0; k < 3; ++k) {
      int i = v[k], j = v[(k + 1) % 3];
      int ox = off[(k + 1) % 3][0] - off[k][0], oy = off[(k + 1) % 3][1] - off[k][1];
      if (j < i || (i == j && (ox < 0 || (ox == 0 && oy < 0)))) {
        std::swap(i, j);
        ox = -ox;
        oy = -oy;
      }
      if (!seen.emplace(std::tuple{i, j, ox, oy}, true).second) continue;
      const Eigen::Vector2d ref = pts.col(j) + side * Eigen::Vector2d(ox, oy) - pts.col(i);
      net.edges.push_back({i, j, ref, ref.norm()});
    }
  }
  return net;
}

DisorderedSample analyse_disordered(const DisorderOptions& o, const NetworkMaterial& m,
                                    unsigned seed, const RelaxOptions& relax) {
  const PeriodicNetwork net = make_disordered_network(o, seed);
  DisorderedSample s;
  s.vertices = net.vertex_count();
  const std::vector<int> deg = vertex_degrees(net);
  s.degree6_fraction = static_cast<double>(std::count(deg.begin(), deg.end(), 6)) /
                       std::max<std::size_t>(1, deg.size());
  const double area = net.reference_area_um2();
  double sum_l2 = 0.0;
  for (const PeriodicEdge& e : net.edges) sum_l2 += e.lbar_um * e.lbar_um;
  s.phi_over_area = (0.5 * sum_l2 - units::sqrt3 * area) / area;
  const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
  const Eigen::Matrix2Xd U0 = Eigen::Matrix2Xd::Zero(2, net.vertex_count());
  s.psi_reference_pN_per_um = patch_energy(net, m, I, U0) / area;
  s.affine = moduli_from_tangent(patch_hessian(net, m, I, U0).ff / area);
  const HomogenisedState h = homogenise_patch(net, m, I, U0, relax);
  s.relax = h.relax;
  s.psi_relaxed_pN_per_um = h.psi_pN_per_um;
  s.relaxed = moduli_from_tangent(h.relaxed_tangent);
  s.affine_at_relaxed = moduli_from_tangent(h.affine_tangent);
  s.prestress_pN_per_um = 0.5 * h.stress.trace();
  return s;
}

MeanStd mean_std(const std::vector<double>& v) {
  MeanStd r;
  if (v.empty()) return r;
  for (double x : v) r.mean += x;
  r.mean /= v.size();
  if (v.size() > 1) {
    double ss = 0.0;
    for (double x : v) ss += (x - r.mean) * (x - r.mean);
    r.std = std::sqrt(ss / (v.size() - 1));
  }
  return r;
}

std::vector<DisorderedSample> disordered_study(const DisorderOptions& o, const NetworkMaterial& m,
                                               int seeds, unsigned first_seed,
                                               const RelaxOptions& relax,
                                               const ProgressSink& progress) {
  if (seeds < 1) throw std::invalid_argument("--seeds must be >= 1, got " + std::to_string(seeds));
  std::vector<DisorderedSample> out;
  for (int k = 0; k < seeds; ++k) {
    out.push_back(analyse_disordered(o, m, first_seed + k, relax));
    const DisorderedSample& s = out.back();
    report(progress, "seed " + std::to_string(first_seed + k) + ": " + std::to_string(s.vertices) +
                         " vertices, degree-6 " + std::to_string(s.degree6_fraction) +
                         ", mu relaxed " + std::to_string(s.relaxed.mu_pN_per_um) + " pN/um, " +
                         std::to_string(s.relax.iterations) + " Newton iterations");
  }
  return out;
}

}  // namespace rbc
