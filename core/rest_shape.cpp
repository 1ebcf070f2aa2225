// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/rest_shape.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>

#include <gsl/gsl_integration.h>

#include "core/geometry.hpp"
#include "core/lbfgs.hpp"
#include "core/mirror_symmetry.hpp"
#include "core/units.hpp"

namespace rbc {

Eigen::Vector3d evans_fung_point(const EvansFungShape& sh, const Eigen::Vector3d& s) {
  const double t = s.x() * s.x() + s.y() * s.y();
  const double g = sh.c0 + sh.c1 * t + sh.c2 * t * t;
  return sh.radius_um * Eigen::Vector3d(s.x(), s.y(), s.z() * g);
}

Eigen::Matrix3d evans_fung_jacobian(const EvansFungShape& sh, const Eigen::Vector3d& s) {
  const double t = s.x() * s.x() + s.y() * s.y();
  const double g = sh.c0 + sh.c1 * t + sh.c2 * t * t;
  const double dg = sh.c1 + 2.0 * sh.c2 * t;
  Eigen::Matrix3d j = Eigen::Matrix3d::Zero();
  j(0, 0) = 1.0;
  j(1, 1) = 1.0;
  j(2, 0) = 2.0 * s.z() * dg * s.x();
  j(2, 1) = 2.0 * s.z() * dg * s.y();
  j(2, 2) = g;
  return sh.radius_um * j;
}

double equilateral_defect(const Positions& x, const Topology& topo, Positions* grad) {
  double half_sum_l2 = 0.0, area = 0.0;
  if (grad) grad->setZero(3, x.cols());
  for (int e = 0; e < topo.num_edges(); ++e) {
    const int a = topo.edges(0, e), b = topo.edges(1, e);
    const Eigen::Vector3d d = x.col(b) - x.col(a);
    half_sum_l2 += 0.5 * d.squaredNorm();
    if (grad) {
      grad->col(b) += d;
      grad->col(a) -= d;
    }
  }
  Eigen::Matrix3d ga;
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto& t = topo.faces.col(f);
    area += triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)), grad ? &ga : nullptr);
    if (grad)
      for (int k = 0; k < 3; ++k) grad->col(t(k)) -= units::sqrt3 * ga.col(k);
  }
  return half_sum_l2 - units::sqrt3 * area;
}

TriMesh make_icosphere(int frequency) {
  if (frequency < 1) throw std::invalid_argument("icosphere frequency must be >= 1");
  // Icosahedron with vertices at the poles (the dimple centres on the cell).
  std::vector<Eigen::Vector3d> corner(12);
  corner[0] = {0, 0, 1};
  corner[11] = {0, 0, -1};
  const double lat = std::atan(0.5);
  for (int k = 0; k < 5; ++k) {
    const double a0 = 2.0 * units::pi * k / 5.0, a1 = a0 + units::pi / 5.0;
    corner[1 + k] = {std::cos(lat) * std::cos(a0), std::cos(lat) * std::sin(a0), std::sin(lat)};
    corner[6 + k] = {std::cos(lat) * std::cos(a1), std::cos(lat) * std::sin(a1), -std::sin(lat)};
  }
  std::vector<std::array<int, 3>> ico;
  for (int k = 0; k < 5; ++k) {
    const int u0 = 1 + k, u1 = 1 + (k + 1) % 5, l0 = 6 + k, l1 = 6 + (k + 1) % 5;
    ico.push_back({0, u0, u1});
    ico.push_back({u0, l0, u1});
    ico.push_back({u1, l0, l1});
    ico.push_back({11, l1, l0});
  }
  // Points on each face at integer barycentrics (i, j, k), i + j + k = f; a point shared
  // by faces is keyed exactly by its (corner, weight) pairs sorted by corner.
  using Key = std::array<int, 6>;
  std::map<Key, int> index;
  std::vector<Eigen::Vector3d> pts;
  auto vertex = [&](const std::array<int, 3>& c, int i, int j) {
    const int k = frequency - i - j;
    std::array<std::pair<int, int>, 3> w{{{c[0], i}, {c[1], j}, {c[2], k}}};
    std::sort(w.begin(), w.end());
    Key key{-1, 0, -1, 0, -1, 0};
    int n = 0;
    for (const auto& [id, wt] : w)
      if (wt > 0) {
        key[2 * n] = id;
        key[2 * n + 1] = wt;
        ++n;
      }
    auto [it, fresh] = index.emplace(key, static_cast<int>(pts.size()));
    if (fresh)
      pts.push_back(
          ((i * corner[c[0]] + j * corner[c[1]] + k * corner[c[2]]) / frequency).normalized());
    return it->second;
  };
  std::vector<std::array<int, 3>> tris;
  for (const auto& c : ico) {
    // Row i counts steps from corner 0 towards corner 1, j towards corner 2.
    for (int i = 0; i < frequency; ++i)
      for (int j = 0; i + j < frequency; ++j) {
        // bary (i,j) refers to weights: corner0 = f-i-j ... use (w0, w1, w2) = (f-i-j, i, j)
        auto v = [&](int ii, int jj) {
          return vertex({c[1], c[2], c[0]}, ii, jj);  // weights (ii, jj, f-ii-jj)
        };
        tris.push_back({v(i, j), v(i + 1, j), v(i, j + 1)});
        if (i + j + 1 < frequency) tris.push_back({v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)});
      }
  }
  TriMesh mesh;
  mesh.x.resize(3, static_cast<Eigen::Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) mesh.x.col(static_cast<Eigen::Index>(i)) = pts[i];
  Faces faces(3, static_cast<Eigen::Index>(tris.size()));
  for (size_t f = 0; f < tris.size(); ++f) {
    auto t = tris[f];
    // Orient outward: the normal must point away from the origin.
    const Eigen::Vector3d n = (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]);
    if (n.dot(pts[t[0]] + pts[t[1]] + pts[t[2]]) < 0) std::swap(t[1], t[2]);
    faces.col(static_cast<Eigen::Index>(f)) << t[0], t[1], t[2];
  }
  mesh.topo = build_topology(faces, static_cast<int>(pts.size()));
  return mesh;
}

int icosphere_frequency_for(int vertices) {
  const double f = std::sqrt(std::max(vertices - 2, 10) / 10.0);
  const int lo = std::max(1, static_cast<int>(std::floor(f)));
  const int hi = lo + 1;
  auto count = [](int q) { return 10 * q * q + 2; };
  return std::abs(count(lo) - vertices) <= std::abs(count(hi) - vertices) ? lo : hi;
}

namespace {

// Equal-area remap of the polar angle: the sphere's cumulative area fraction
// (1 - cos t)/2 is matched on the cell's meridian P(t') by tabulation.
Eigen::Vector3d equal_area_sphere_point(const EvansFungShape& sh, const Eigen::Vector3d& s,
                                        const std::vector<double>& cumulative) {
  const int n = static_cast<int>(cumulative.size()) - 1;
  const double target = 0.5 * (1.0 - std::clamp(s.z(), -1.0, 1.0));
  const auto it = std::lower_bound(cumulative.begin(), cumulative.end(), target);
  int k = std::clamp(static_cast<int>(it - cumulative.begin()), 1, n);
  const double w =
      (target - cumulative[k - 1]) / std::max(cumulative[k] - cumulative[k - 1], 1e-300);
  const double tp = units::pi * (k - 1 + std::clamp(w, 0.0, 1.0)) / n;
  const double phi = std::atan2(s.y(), s.x());
  (void)sh;
  return {std::sin(tp) * std::cos(phi), std::sin(tp) * std::sin(phi), std::cos(tp)};
}

std::vector<double> meridian_area_fraction(const EvansFungShape& sh, int n) {
  std::vector<double> cum(n + 1, 0.0);
  auto point = [&](double t) {
    return evans_fung_point(sh, Eigen::Vector3d(std::sin(t), 0.0, std::cos(t)));
  };
  for (int k = 1; k <= n; ++k) {
    const double t0 = units::pi * (k - 1) / n, t1 = units::pi * k / n;
    const Eigen::Vector3d p0 = point(t0), p1 = point(t1);
    cum[k] = cum[k - 1] + units::pi * (p0.x() + p1.x()) * (p1 - p0).norm();  // frustum
  }
  for (auto& c : cum) c /= cum[n];
  return cum;
}

}  // namespace

EvansFungMeasures evans_fung_measures(const EvansFungShape& sh) {
  // In the meridian angle t in [0, pi/2] (upper half): r = R sin t, z = R cos t g(sin^2 t);
  // the integrands are smooth there, unlike in r where z'(r) blows up at the rim.
  struct Ctx {
    const EvansFungShape* sh;
  } ctx{&sh};
  gsl_function area_f, volume_f;
  area_f.params = volume_f.params = &ctx;
  area_f.function = [](double t, void* p) {
    const auto& s = *static_cast<Ctx*>(p)->sh;
    const Eigen::Vector3d x = evans_fung_point(s, Eigen::Vector3d(std::sin(t), 0.0, std::cos(t)));
    const Eigen::Vector3d dx =
        evans_fung_jacobian(s, Eigen::Vector3d(std::sin(t), 0.0, std::cos(t))) *
        Eigen::Vector3d(std::cos(t), 0.0, -std::sin(t));
    return 2.0 * units::pi * x.x() * std::hypot(dx.x(), dx.z());
  };
  volume_f.function = [](double t, void* p) {
    const auto& s = *static_cast<Ctx*>(p)->sh;
    const Eigen::Vector3d x = evans_fung_point(s, Eigen::Vector3d(std::sin(t), 0.0, std::cos(t)));
    const Eigen::Vector3d dx =
        evans_fung_jacobian(s, Eigen::Vector3d(std::sin(t), 0.0, std::cos(t))) *
        Eigen::Vector3d(std::cos(t), 0.0, -std::sin(t));
    return units::pi * x.x() * x.x() * (-dx.z());  // disc slices: pi r^2 dz
  };
  gsl_integration_workspace* ws = gsl_integration_workspace_alloc(1000);
  double area = 0, volume = 0, err = 0;
  gsl_integration_qags(&area_f, 0.0, units::pi / 2, 0.0, 1e-12, 1000, ws, &area, &err);
  gsl_integration_qags(&volume_f, 0.0, units::pi / 2, 0.0, 1e-12, 1000, ws, &volume, &err);
  gsl_integration_workspace_free(ws);
  return {2.0 * area, 2.0 * volume, 2.0 * sh.radius_um};
}

MeshQualityReport assess_mesh(const TriMesh& mesh) {
  MeshQualityReport r;
  const auto& t = mesh.topo;
  r.vertices = t.num_vertices;
  r.edges = t.num_edges();
  r.faces = t.num_faces();
  r.area_um2 = total_area(mesh.x, t);
  r.volume_um3 = enclosed_volume(mesh.x, t);
  const Diameters d = measure_diameters(mesh.x);
  r.diameter_um = 0.5 * (d.axial_um + d.transverse_um);
  r.thickness_um = mesh.x.row(2).maxCoeff() - mesh.x.row(2).minCoeff();
  r.phi_over_area = equilateral_defect(mesh.x, t) / r.area_um2;
  const Eigen::VectorXd l = edge_lengths(mesh.x, t);
  r.edge_min_um = l.minCoeff();
  r.edge_mean_um = l.mean();
  r.edge_max_um = l.maxCoeff();
  for (int f = 0; f < t.num_faces(); ++f) {
    const auto& c = t.faces.col(f);
    r.worst_aspect_ratio =
        std::max(r.worst_aspect_ratio,
                 triangle_aspect_ratio(mesh.x.col(c(0)), mesh.x.col(c(1)), mesh.x.col(c(2))));
  }
  r.degree_histogram = degree_histogram(t);
  return r;
}

Eigen::Matrix3d triangulation_rotation(unsigned rotation_seed) {
  if (rotation_seed == 0) return Eigen::Matrix3d::Identity();
  std::mt19937_64 rng(rotation_seed);
  // 53-bit uniforms in [0, 1) from the raw stream: the same numbers on every standard library.
  auto uniform = [&rng] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  const double u1 = uniform(), u2 = 2 * M_PI * uniform(), u3 = 2 * M_PI * uniform();
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  const Eigen::Quaterniond q(a * std::sin(u2), a * std::cos(u2), b * std::sin(u3),
                             b * std::cos(u3));  // Shoemake 1992: uniform on SO(3)
  return q.normalized().toRotationMatrix();
}

Eigen::Matrix3d orientation_rotation(TriangulationOrientation orientation) {
  if (orientation == TriangulationOrientation::dimple_vertex) return Eigen::Matrix3d::Identity();
  // make_icosphere's corners 0 (the north pole) and 1 (latitude atan(1/2), longitude 0) share
  // an edge. The icosahedron's two-fold axis through that edge's midpoint, the axis along the
  // edge itself and the axis normal to both are mutually orthogonal two-fold axes; each is
  // normal to a mirror plane of the icosahedron. They are turned onto z, y and x.
  const double lat = std::atan(0.5);
  const Eigen::Vector3d c0(0, 0, 1), c1(std::cos(lat), 0, std::sin(lat));
  const Eigen::Vector3d a = (c0 + c1).normalized(), b = (c1 - c0).normalized(), c = b.cross(a);
  Eigen::Matrix3d r;
  r.row(0) = c.transpose();
  r.row(1) = b.transpose();
  r.row(2) = a.transpose();
  return r;  // rows orthonormal, det = c.(b x a) = +1
}

TriMesh make_rest_shape(const RestShapeOptions& opt, MeshQualityReport* report) {
  if (opt.target_vertices < 100 || opt.target_vertices > 40000)
    throw std::invalid_argument("vertex count " + std::to_string(opt.target_vertices) +
                                " is outside the supported range [100, 40000]");
  if (!(opt.shape.radius_um > 0))
    throw std::invalid_argument("Evans-Fung radius must be positive, got " +
                                std::to_string(opt.shape.radius_um) + " um");
  TriMesh sphere = make_icosphere(icosphere_frequency_for(opt.target_vertices));
  if (opt.orientation != TriangulationOrientation::dimple_vertex)
    sphere.x = orientation_rotation(opt.orientation) * sphere.x;
  if (opt.rotation_seed != 0) sphere.x = triangulation_rotation(opt.rotation_seed) * sphere.x;
  const int n = sphere.topo.num_vertices;
  // The mirror-planes icosphere is symmetric to rounding; the Phi minimisation keeps that only
  // up to its drift (1e-8 um at 40,000 vertices, enough to lose mirrors at find_mirror_
  // symmetry's tolerance), so its result is averaged over each orbit below.
  MeshSymmetry mirrors;
  if (opt.orientation == TriangulationOrientation::mirror_planes && opt.rotation_seed == 0) {
    mirrors = find_mirror_symmetry(sphere.x, sphere.topo, 1e-9);
    if (mirrors.order() != 8)
      throw std::logic_error("mirror-planes icosphere keeps " + std::to_string(mirrors.order()) +
                             " of the 8 mirrors");
  }
  Positions s = sphere.x;  // points on the unit sphere (the surface parameters)
  if (opt.quality == RestMeshQuality::equal_area) {
    const auto cum = meridian_area_fraction(opt.shape, 20000);
    for (int i = 0; i < n; ++i) s.col(i) = equal_area_sphere_point(opt.shape, s.col(i), cum);
  }
  int iterations = 0;
  if (opt.quality == RestMeshQuality::phi_minimised) {
    // Minimise Phi(P(u/|u|)) over unconstrained u in R^3 per vertex: vertices slide on
    // the surface; the radial direction of u is a harmless flat direction.
    const Topology& topo = sphere.topo;
    Objective phi = [&](const Eigen::VectorXd& u, Eigen::VectorXd& grad) {
      Positions x(3, n);
      Eigen::Map<const Eigen::Matrix3Xd> um(u.data(), 3, n);
      for (int i = 0; i < n; ++i) x.col(i) = evans_fung_point(opt.shape, um.col(i).normalized());
      Positions gx;
      const double value = equilateral_defect(x, topo, &gx);
      Eigen::Map<Eigen::Matrix3Xd> gu(grad.data(), 3, n);
      for (int i = 0; i < n; ++i) {
        const double r = um.col(i).norm();
        const Eigen::Vector3d sh = um.col(i) / r;
        const Eigen::Matrix3d ds_du = (Eigen::Matrix3d::Identity() - sh * sh.transpose()) / r;
        gu.col(i) =
            ds_du.transpose() * (evans_fung_jacobian(opt.shape, sh).transpose() * gx.col(i));
      }
      return value;
    };
    LbfgsOptions lo;
    lo.max_iterations = opt.max_phi_iterations;
    // Mean edge of an icosphere with n vertices on the unit sphere is ~3.81/sqrt(n).
    const double mean_edge_um = 3.81 / std::sqrt(static_cast<double>(n)) * opt.shape.radius_um;
    lo.force_tolerance = opt.phi_tolerance * mean_edge_um;
    lo.max_step = 0.3 * 3.81 / std::sqrt(static_cast<double>(n));  // in sphere units
    Eigen::VectorXd u = flat(s);
    const MinimiserResult r = minimise_lbfgs(phi, u, lo);
    iterations = r.iterations;
    for (int i = 0; i < n; ++i) s.col(i) = u.segment<3>(3 * i).normalized();
  }
  if (mirrors.order() > 1) {  // s_i = mean over g of S_g s_{g(i)}: symmetric to rounding
    Positions sym = Positions::Zero(3, n);
    for (int g = 0; g < mirrors.order(); ++g) {
      const int mask = mirrors.reflections[static_cast<size_t>(g)];
      const Eigen::Vector3d sg(reflection_sign(mask, 0), reflection_sign(mask, 1),
                               reflection_sign(mask, 2));
      for (int i = 0; i < n; ++i)
        sym.col(i) +=
            s.col(mirrors.image[static_cast<size_t>(g)][static_cast<size_t>(i)]).cwiseProduct(sg);
    }
    for (int i = 0; i < n; ++i) s.col(i) = sym.col(i).normalized();
  }
  TriMesh mesh;
  mesh.topo = sphere.topo;
  mesh.x.resize(3, n);
  for (int i = 0; i < n; ++i) mesh.x.col(i) = evans_fung_point(opt.shape, s.col(i));
  double scale = 1.0;
  if (opt.match_volume) {
    scale =
        std::cbrt(evans_fung_measures(opt.shape).volume_um3 / enclosed_volume(mesh.x, mesh.topo));
    mesh.x *= scale;  // the shape is centred at the origin
  }
  if (report) {
    *report = assess_mesh(mesh);
    report->phi_iterations = iterations;
    report->volume_scale = scale;
  }
  return mesh;
}

std::string to_string(RestMeshQuality q) {
  switch (q) {
    case RestMeshQuality::phi_minimised:
      return "phi-minimised";
    case RestMeshQuality::projected:
      return "projected";
    case RestMeshQuality::equal_area:
      return "equal-area";
  }
  return "unknown";
}

RestMeshQuality rest_mesh_quality_from_string(const std::string& name) {
  for (auto q :
       {RestMeshQuality::phi_minimised, RestMeshQuality::projected, RestMeshQuality::equal_area})
    if (to_string(q) == name) return q;
  throw std::invalid_argument("unknown mesh quality '" + name +
                              "', expected phi-minimised, projected or equal-area");
}

std::string to_string(TriangulationOrientation o) {
  switch (o) {
    case TriangulationOrientation::dimple_vertex:
      return "dimple-vertex";
    case TriangulationOrientation::mirror_planes:
      return "mirror-planes";
  }
  return "unknown";
}

TriangulationOrientation triangulation_orientation_from_string(const std::string& name) {
  for (auto o : {TriangulationOrientation::dimple_vertex, TriangulationOrientation::mirror_planes})
    if (to_string(o) == name) return o;
  throw std::invalid_argument("unknown triangulation orientation '" + name +
                              "', expected dimple-vertex or mirror-planes");
}

}  // namespace rbc
