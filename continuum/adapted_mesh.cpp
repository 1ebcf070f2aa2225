// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/adapted_mesh.hpp"

#include <CGAL/Complex_2_in_triangulation_3.h>
#include <CGAL/Implicit_surface_3.h>
#include <CGAL/Surface_mesh_default_triangulation_3.h>
#include <CGAL/Surface_mesher/Standard_criteria.h>
#include <CGAL/make_surface_mesh.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <queue>
#include <stdexcept>
#include <string>
#include <vector>

#include "continuum/contact_load.hpp"
#include "continuum/continuum_model.hpp"
#include "core/validation.hpp"

namespace rbc {

// Named (as well as file-local) so that its names cannot meet another file's in a unity batch.
namespace adapted_mesh_internal {
namespace {

/// A triangulation base (vertex or cell) with a time stamp: CGAL's Compact_container then
/// orders handles by creation (as Mesh_3's bases do) instead of by memory address, so the
/// mesher's queues (ordered by handle among equal qualities) and so its output are the same
/// from run to run.
template <class Base>
class TimeStamped : public Base {
 public:
  template <class Tds2>
  struct Rebind_TDS {
    using Base2 = typename Base::template Rebind_TDS<Tds2>::Other;
    using Other = TimeStamped<Base2>;
  };
  using Base::Base;
  using Has_timestamp = CGAL::Tag_true;
  std::size_t time_stamp() const { return time_stamp_; }
  void set_time_stamp(const std::size_t& ts) { time_stamp_ = ts; }

 private:
  std::size_t time_stamp_ = std::size_t(-1);  // -1: Compact_container assigns one
};

// CGAL::Surface_mesh_default_triangulation_3 with time-stamped vertices and cells.
using Kernel =
    CGAL::Robust_circumcenter_traits_3<CGAL::Exact_predicates_inexact_constructions_kernel>;
using Vb = TimeStamped<CGAL::Surface_mesh_vertex_base_3<Kernel>>;
using Cb = TimeStamped<CGAL::Delaunay_triangulation_cell_base_with_circumcenter_3<
    Kernel, CGAL::Surface_mesh_cell_base_3<Kernel>>>;
using Tr = CGAL::Delaunay_triangulation_3<Kernel, CGAL::Triangulation_data_structure_3<Vb, Cb>>;
using C2t3 = CGAL::Complex_2_in_triangulation_3<Tr>;
using GT = Tr::Geom_traits;
using Point3 = GT::Point_3;
using FT = GT::FT;

/// The level function as the mesher's implicit function (a functor: FT operator()(Point_3)).
struct LevelFunction {
  EvansFungShape shape;
  FT operator()(const Point3& p) const {
    return evans_fung_level(
        shape, Vec3(CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z())));
  }
};
using Surface = CGAL::Implicit_surface_3<GT, LevelFunction>;

/// Bad facet: its surface Delaunay ball's radius exceeds size(c)/sqrt(3) at the ball's centre c.
class SizeFieldCriterion : public CGAL::Surface_mesher::Refine_criterion<Tr> {
 public:
  using Quality = CGAL::Surface_mesher::Refine_criterion<Tr>::Quality;
  explicit SizeFieldCriterion(const SizeField& size) : size_(size) {}
  bool is_bad(const Tr::Facet& fh, Quality& q) const override {
    const Point3& p1 = fh.first->vertex((fh.second + 1) & 3)->point();
    const Point3 c = fh.first->get_facet_surface_center(fh.second);
    const double h_um =
        size_(Vec3(CGAL::to_double(c.x()), CGAL::to_double(c.y()), CGAL::to_double(c.z())));
    const double r2 = h_um * h_um / 3.0;
    const double d2 = CGAL::to_double(CGAL::squared_distance(p1, c));
    q = d2 > 0 ? r2 / d2 : 1.0;
    return q < 1.0;
  }

 private:
  const SizeField& size_;
};

/// The facet criteria: smallest angle, then the size field (CGAL::Surface_mesh_default_criteria_3
/// with the uniform radius bound replaced by the field).
class GradedCriteria {
  using Criterion = CGAL::Surface_mesher::Refine_criterion<Tr>;
  using Criteria = CGAL::Surface_mesher::Standard_criteria<Criterion>;

 public:
  using Quality = Criteria::Quality;
  using Facet = Tr::Facet;
  GradedCriteria(const SizeField& size, double min_angle_deg) : size_(size), angle_(min_angle_deg) {
    list_ = {&angle_, &size_};
    criteria_.set_criteria(list_);
  }
  GradedCriteria(const GradedCriteria&) = delete;
  GradedCriteria& operator=(const GradedCriteria&) = delete;
  bool is_bad(const Facet& f, Quality& q) const { return criteria_.is_bad(f, q); }

 private:
  SizeFieldCriterion size_;
  CGAL::Surface_mesher::Aspect_ratio_criterion<Tr> angle_;
  std::vector<Criterion*> list_;
  Criteria criteria_;
};

/// Orients the faces consistently (breadth-first over shared edges) and outward (positive
/// enclosed volume). std::runtime_error if an edge is not shared by exactly two faces or the
/// surface is not orientable.
void orient_outward(const Positions& x, Faces& faces) {
  const int nf = static_cast<int>(faces.cols());
  std::map<std::pair<int, int>, std::vector<int>> edge_faces;
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(k, f), b = faces((k + 1) % 3, f);
      edge_faces[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  for (const auto& [e, fs] : edge_faces)
    if (fs.size() != 2)
      throw std::runtime_error("adapted mesh: edge (" + std::to_string(e.first) + ", " +
                               std::to_string(e.second) + ") lies in " + std::to_string(fs.size()) +
                               " faces, expected 2");
  auto directed = [&](int f, int a, int b) {  // does face f traverse a -> b?
    for (int k = 0; k < 3; ++k)
      if (faces(k, f) == a && faces((k + 1) % 3, f) == b) return true;
    return false;
  };
  std::vector<int> done(nf, 0);
  for (int seed = 0; seed < nf; ++seed) {
    if (done[seed]) continue;
    done[seed] = 1;
    std::queue<int> todo;
    todo.push(seed);
    while (!todo.empty()) {
      const int f = todo.front();
      todo.pop();
      for (int k = 0; k < 3; ++k) {
        const int a = faces(k, f), b = faces((k + 1) % 3, f);
        const auto& fs = edge_faces.at({std::min(a, b), std::max(a, b)});
        const int g = fs[0] == f ? fs[1] : fs[0];
        if (done[g]) {
          if (directed(g, a, b))
            throw std::runtime_error("adapted mesh: the surface is not orientable");
          continue;
        }
        if (directed(g, a, b)) std::swap(faces(1, g), faces(2, g));
        done[g] = 1;
        todo.push(g);
      }
    }
  }
  double volume = 0;
  for (int f = 0; f < nf; ++f)
    volume += x.col(faces(0, f)).dot(x.col(faces(1, f)).cross(x.col(faces(2, f))));
  if (volume < 0) faces.row(1).swap(faces.row(2));
}

double smallest_size_on_surface(const EvansFungShape& shape, const SizeField& size_um) {
  // Checks the field on the images of an icosphere's vertices.
  const TriMesh sphere = make_icosphere(8);
  double smallest = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < sphere.x.cols(); ++i) {
    const double h = size_um(evans_fung_point(shape, sphere.x.col(i)));
    if (!std::isfinite(h) || !(h > 0))
      throw std::invalid_argument("mesh size field must be finite and > 0 on the surface, got " +
                                  std::to_string(h) + " um");
    smallest = std::min(smallest, h);
  }
  return smallest;
}

TriMesh mesh_surface(const EvansFungShape& shape, const SizeField& size_um, unsigned seed,
                     double min_angle_deg) {
  require_finite_in_range("smallest angle", "degrees", min_angle_deg, 10.0, 30.0,
                          Ends::closed_closed);
  smallest_size_on_surface(shape, size_um);
  Tr tr;
  C2t3 c2t3(tr);
  // Deterministic initial points on the surface: the images of a frequency-3 icosphere's 92
  // vertices (turned by the seed's rotation), instead of the mesher's random ones (which
  // CGAL draws from its process-wide generator).
  const TriMesh sphere = make_icosphere(3);
  const Eigen::Matrix3d turn = triangulation_rotation(seed);
  std::vector<Point3> initial;
  for (Eigen::Index i = 0; i < sphere.x.cols(); ++i) {
    const Vec3 p = evans_fung_point(shape, turn * sphere.x.col(i));
    initial.emplace_back(p.x(), p.y(), p.z());
  }
  tr.insert(initial.begin(), initial.end());
  const double bound_um = 1.2 * shape.radius_um;
  const Surface surface(LevelFunction{shape}, GT::Sphere_3(CGAL::ORIGIN, bound_um * bound_um),
                        1e-10);
  const GradedCriteria criteria(size_um, min_angle_deg);
  CGAL::make_surface_mesh(c2t3, surface, criteria, CGAL::Manifold_tag(), 0);

  // Vertices of the complex in the triangulation's (deterministic) order, faces as listed.
  std::map<Tr::Vertex_handle, int> index;
  std::vector<Vec3> points;
  for (auto v = tr.finite_vertices_begin(); v != tr.finite_vertices_end(); ++v) {
    if (c2t3.face_status(v) == C2t3::NOT_IN_COMPLEX) continue;
    index[v] = static_cast<int>(points.size());
    const Point3& p = v->point();
    points.emplace_back(CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z()));
  }
  Faces faces(3, c2t3.number_of_facets());
  int nf = 0;
  for (auto f = c2t3.facets_begin(); f != c2t3.facets_end(); ++f, ++nf)
    for (int k = 0; k < 3; ++k) {
      const auto v = f->first->vertex(tr.vertex_triple_index(f->second, k));
      const auto it = index.find(v);
      if (it == index.end())
        throw std::runtime_error("adapted mesh: a facet vertex is not in the complex");
      faces(k, nf) = it->second;
    }
  Positions x(3, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i)
    x.col(static_cast<Eigen::Index>(i)) = evans_fung_project(shape, points[i]);
  orient_outward(x, faces);
  TriMesh mesh;
  mesh.x = std::move(x);
  mesh.topo = build_topology(faces, static_cast<int>(mesh.x.cols()));
  const int euler = mesh.topo.num_vertices - mesh.topo.num_edges() + mesh.topo.num_faces();
  if (euler != 2)
    throw std::runtime_error("adapted mesh: Euler characteristic " + std::to_string(euler) +
                             ", expected 2 (a sphere); the size field is too coarse for the "
                             "surface");
  return mesh;
}

}  // namespace
}  // namespace adapted_mesh_internal

double evans_fung_level(const EvansFungShape& s, const Vec3& p) {
  const double r = s.radius_um;
  const double t = (p.x() * p.x() + p.y() * p.y()) / (r * r);
  const double tc = std::min(t, 1.0);
  const double g = s.c0 + s.c1 * tc + s.c2 * tc * tc;
  const double z = p.z() / r;
  return z * z - (1.0 - t) * g * g;
}

Vec3 evans_fung_level_gradient(const EvansFungShape& s, const Vec3& p) {
  const double r = s.radius_um;
  const double t = (p.x() * p.x() + p.y() * p.y()) / (r * r);
  const bool inside = t < 1.0;
  const double tc = inside ? t : 1.0;
  const double g = s.c0 + s.c1 * tc + s.c2 * tc * tc;
  const double dg = inside ? s.c1 + 2.0 * s.c2 * tc : 0.0;
  // f = z^2/R^2 - (1 - t) g^2: df/dt = g^2 - (1 - t) 2 g g'; dt/dx = 2x/R^2.
  const double df_dt = g * g - (1.0 - t) * 2.0 * g * dg;
  return {df_dt * 2.0 * p.x() / (r * r), df_dt * 2.0 * p.y() / (r * r), 2.0 * p.z() / (r * r)};
}

Vec3 evans_fung_project(const EvansFungShape& shape, Vec3 x_um) {
  for (int it = 0; it < 20; ++it) {
    const double f = evans_fung_level(shape, x_um);
    const Vec3 g = evans_fung_level_gradient(shape, x_um);
    const Vec3 step = f / g.squaredNorm() * g;
    x_um -= step;
    if (step.norm() < 1e-15 * shape.radius_um) break;
  }
  return x_um;
}

double SceneSizeField::operator()(const Vec3& x_um) const {
  const double start = plane_um - band_um;
  const double d = std::max(0.0, start - std::abs(x_um.x()));
  return std::min(coarse_um, fine_um + grading * d);
}

double rest_contact_plane(const EvansFungShape& shape, double contact_fraction) {
  require_finite_in_range("contact fraction", "", contact_fraction, 0.0, 0.5, Ends::open_open);
  RestShapeOptions o;
  o.shape = shape;
  o.quality = RestMeshQuality::projected;
  o.match_volume = false;
  o.target_vertices = 36002;
  const TriMesh fine = make_rest_shape(o);
  const double area = total_area(fine.x, fine.topo);
  return cap_plane_for_area(fine.x, fine.topo, contact_fraction * area, +1);
}

TriMesh mesh_evans_fung_surface(const EvansFungShape& shape, const SizeField& size_um,
                                unsigned seed, double min_angle_deg) {
  return adapted_mesh_internal::mesh_surface(shape, size_um, seed, min_angle_deg);
}

void AdaptedMeshOptions::validate() const {
  require_integer_in_range("elements", target_elements, kMinContinuumElements,
                           kMaxContinuumElements);
  require_finite_in_range("mesh size ratio", "", size_ratio, 1.0, 10.0, Ends::closed_closed);
  require_finite_in_range("contact fraction", "", contact_fraction, 0.0, 0.5, Ends::open_open);
  require_finite_in_range("fine band", "fine sizes", band_fine_sizes, 0.0, 20.0,
                          Ends::closed_closed);
  require_finite_in_range("mesh grading", "", grading, 0.0, 2.0, Ends::open_closed);
  require_finite_in_range("smallest angle", "degrees", min_angle_deg, 10.0, 30.0,
                          Ends::closed_closed);
  require_finite_in_range("element tolerance", "", element_tolerance, 0.0, 1.0, Ends::open_open);
  require_integer_in_range("mesh passes", max_passes, 1, 50);
}

TriMesh make_adapted_mesh(const AdaptedMeshOptions& o, AdaptedMeshReport* report) {
  o.validate();
  const EvansFungMeasures exact = evans_fung_measures(o.shape);
  SceneSizeField field;
  field.plane_um = rest_contact_plane(o.shape, o.contact_fraction);
  field.grading = o.grading;
  // First guess: an equilateral triangle of edge a covers sqrt(3)/4 a^2, and the mesher's mean
  // edge is about 0.75 h (measured: 0.72 to 0.77), so the count is about
  // (4/sqrt3) integral dA / (0.75 h)^2, estimated on a projected icosphere's vertex areas.
  RestShapeOptions ro;
  ro.shape = o.shape;
  ro.quality = RestMeshQuality::projected;
  ro.match_volume = false;
  ro.target_vertices = 4000;
  const TriMesh probe = make_rest_shape(ro);
  const Eigen::VectorXd vertex_area = vertex_areas(probe.x, probe.topo);
  auto field_for = [&](double fine_um) {
    SceneSizeField f = field;
    f.fine_um = fine_um;
    f.coarse_um = o.size_ratio * fine_um;
    f.band_um = o.band_fine_sizes * fine_um;
    return f;
  };
  auto predicted = [&](double fine_um) {
    const SceneSizeField f = field_for(fine_um);
    double n = 0;
    for (Eigen::Index i = 0; i < probe.x.cols(); ++i) {
      const double h = 0.75 * f(probe.x.col(i));
      n += vertex_area(i) / (h * h);
    }
    return 4.0 / std::sqrt(3.0) * n;
  };
  // Solve predicted(fine) = target by bisection in log(fine) (predicted is decreasing).
  double lo = 1e-3, hi = exact.diameter_um;
  for (int it = 0; it < 100; ++it) {
    const double mid = std::sqrt(lo * hi);
    (predicted(mid) > o.target_elements ? lo : hi) = mid;
  }
  double fine_um = std::sqrt(lo * hi);
  TriMesh mesh;
  int passes = 0;
  for (; passes < o.max_passes;) {
    field = field_for(fine_um);
    ++passes;
    mesh = mesh_evans_fung_surface(o.shape, field, o.seed, o.min_angle_deg);
    const double ratio = static_cast<double>(mesh.topo.num_faces()) / o.target_elements;
    if (std::abs(ratio - 1.0) <= o.element_tolerance) break;
    fine_um *= std::sqrt(ratio);  // the count goes as 1/h^2
  }
  double scale = 1.0;
  if (o.match_volume) {
    scale = std::cbrt(exact.volume_um3 / enclosed_volume(mesh.x, mesh.topo));
    mesh.x *= scale;  // the shape is centred at the origin
  }
  if (report) {
    report->size = field;
    report->passes = passes;
    report->vertices = mesh.topo.num_vertices;
    report->elements = mesh.topo.num_faces();
    report->volume_scale = scale;
  }
  return mesh;
}

double mean_edge_length(const TriMesh& mesh, const std::function<bool(const Vec3&)>& select) {
  double sum = 0;
  int n = 0;
  for (int e = 0; e < mesh.topo.num_edges(); ++e) {
    const Vec3 a = mesh.x.col(mesh.topo.edges(0, e)), b = mesh.x.col(mesh.topo.edges(1, e));
    if (!select(0.5 * (a + b))) continue;
    sum += (a - b).norm();
    ++n;
  }
  return n > 0 ? sum / n : 0.0;
}

}  // namespace rbc
