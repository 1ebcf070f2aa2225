// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/refined_mesh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "continuum/continuum_model.hpp"
#include "core/geometry.hpp"
#include "core/validation.hpp"

namespace rbc {

// Named (as well as file-local) so that its names cannot meet another file's in a unity batch.
namespace refined_mesh_internal {
namespace {

using Tri = std::array<int, 3>;

std::uint64_t edge_key(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
}

Tri sorted(Tri t) {
  std::sort(t.begin(), t.end());
  return t;
}

/// The refinement state: vertices, the red triangles (possibly with hanging nodes), the
/// midpoint of every split edge, and each vertex's image under each element of the group.
struct Refiner {
  const EvansFungShape& shape;
  std::vector<Vec3> x;
  std::vector<Tri> red;
  std::unordered_map<std::uint64_t, int> midpoint;
  std::vector<int> masks;                    ///< the group's sign masks
  std::vector<std::vector<int>> image;       ///< image[g][v]
  std::vector<std::pair<int, int>> parents;  ///< per vertex: the edge it splits (-1: coarse)

  int split(int a, int b) const {
    const auto it = midpoint.find(edge_key(a, b));
    return it == midpoint.end() ? -1 : it->second;
  }
  int midpoint_of(int a, int b) {
    const int m = split(a, b);
    if (m >= 0) return m;
    const int id = static_cast<int>(x.size());
    x.push_back(evans_fung_project(shape, 0.5 * (x[a] + x[b])));
    parents.emplace_back(a, b);
    midpoint.emplace(edge_key(a, b), id);
    return id;
  }
  void red_children(const Tri& t, std::vector<Tri>& out) {
    const int m01 = midpoint_of(t[0], t[1]), m12 = midpoint_of(t[1], t[2]),
              m20 = midpoint_of(t[2], t[0]);
    out.push_back({t[0], m01, m20});
    out.push_back({m01, t[1], m12});
    out.push_back({m20, m12, t[2]});
    out.push_back({m01, m12, m20});
  }
  /// Triangles that must be red for the mesh to close with green bisections alone: two or
  /// more split edges, or a split edge with a split half (two levels finer across it).
  bool needs_red(const Tri& t) const {
    int n = 0;
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3], m = split(a, b);
      if (m < 0) continue;
      ++n;
      if (split(a, m) >= 0 || split(m, b) >= 0) return true;
    }
    return n >= 2;
  }
  /// Images of the vertices created since `first` (every midpoint's image is the midpoint of
  /// its edge's image, which exists when the refinement is symmetric).
  void extend_images(std::size_t first) {
    for (auto& im : image) im.resize(x.size(), -1);
    for (std::size_t v = first; v < x.size(); ++v)
      for (std::size_t g = 0; g < image.size(); ++g) {
        const auto [a, b] = parents[v];
        const int m = split(image[g][a], image[g][b]);
        if (m < 0) throw std::logic_error("refined mesh: the refinement lost the mirror symmetry");
        image[g][v] = m;
      }
  }
};

/// Edge of the equilateral triangle with the same area (um).
double equivalent_edge(const Vec3& a, const Vec3& b, const Vec3& c) {
  return std::sqrt(4.0 / std::sqrt(3.0) * triangle_area(a, b, c));
}

}  // namespace
}  // namespace refined_mesh_internal

double RefinedSizeField::operator()(const Vec3& x_um) const {
  const double ax = std::abs(x_um.x()), ay = std::abs(x_um.y()), az = std::abs(x_um.z());
  const double to_cap = std::max(0.0, (plane_um - band_um) - ax);
  const double to_rim_point = std::sqrt(ax * ax + (ay - rim_y_um) * (ay - rim_y_um) + az * az);
  const double to_rim = std::max(0.0, to_rim_point - rim_band_um);
  return fine_um + grading * std::min(to_cap, to_rim);
}

TriMesh refine_evans_fung_mesh(const TriMesh& coarse, const EvansFungShape& shape,
                               const SizeField& size_um, int max_levels,
                               double symmetry_tolerance_um) {
  using namespace refined_mesh_internal;
  if (max_levels < 0)
    throw std::invalid_argument("refinement levels must be >= 0, got " +
                                std::to_string(max_levels));
  Refiner r{shape, {}, {}, {}, {}, {}, {}};
  const int n0 = static_cast<int>(coarse.x.cols());
  for (int i = 0; i < n0; ++i) r.x.push_back(coarse.x.col(i));
  r.parents.assign(static_cast<std::size_t>(n0), {-1, -1});
  for (int f = 0; f < coarse.topo.num_faces(); ++f)
    r.red.push_back({coarse.topo.faces(0, f), coarse.topo.faces(1, f), coarse.topo.faces(2, f)});
  const MeshSymmetry sym = find_mirror_symmetry(coarse.x, coarse.topo, symmetry_tolerance_um);
  r.masks = sym.reflections;
  r.image = sym.image;

  for (int level = 0; level < max_levels; ++level) {
    // Mark, then close the marked set under the group.
    const std::size_t nt = r.red.size();
    std::vector<char> mark(nt, 0);
    bool any = false;
    for (std::size_t t = 0; t < nt; ++t) {
      const Vec3 &a = r.x[r.red[t][0]], &b = r.x[r.red[t][1]], &c = r.x[r.red[t][2]];
      if (equivalent_edge(a, b, c) > size_um((a + b + c) / 3.0)) mark[t] = 1, any = true;
    }
    if (!any) break;
    std::map<Tri, std::size_t> index;
    for (std::size_t t = 0; t < nt; ++t) index.emplace(sorted(r.red[t]), t);
    std::vector<char> closed = mark;
    for (std::size_t t = 0; t < nt; ++t) {
      if (!mark[t]) continue;
      for (std::size_t g = 1; g < r.image.size(); ++g) {
        const Tri im =
            sorted({r.image[g][r.red[t][0]], r.image[g][r.red[t][1]], r.image[g][r.red[t][2]]});
        const auto it = index.find(im);
        if (it == index.end())
          throw std::logic_error("refined mesh: a triangle's mirror image is not in the mesh");
        closed[it->second] = 1;
      }
    }
    const std::size_t first_new = r.x.size();
    std::vector<Tri> next;
    next.reserve(nt * 2);
    for (std::size_t t = 0; t < nt; ++t) {
      if (closed[t])
        r.red_children(r.red[t], next);
      else
        next.push_back(r.red[t]);
    }
    r.red = std::move(next);
    // Closure: red-refine until every triangle has at most one split edge, split once.
    for (bool changed = true; changed;) {
      changed = false;
      std::vector<Tri> out;
      out.reserve(r.red.size());
      for (const Tri& t : r.red) {
        if (r.needs_red(t)) {
          r.red_children(t, out);
          changed = true;
        } else {
          out.push_back(t);
        }
      }
      r.red = std::move(out);
    }
    r.extend_images(first_new);
  }

  // Green closure: a triangle with one split edge is bisected from its midpoint.
  Faces faces(3, static_cast<Eigen::Index>(r.red.size() * 2));
  Eigen::Index nf = 0;
  auto put = [&](int a, int b, int c) {
    faces(0, nf) = a, faces(1, nf) = b, faces(2, nf) = c;
    ++nf;
  };
  for (const Tri& t : r.red) {
    int k_split = -1, m = -1;
    for (int k = 0; k < 3; ++k) {
      const int s = r.split(t[k], t[(k + 1) % 3]);
      if (s >= 0) k_split = k, m = s;
    }
    if (k_split < 0) {
      put(t[0], t[1], t[2]);
    } else {
      const int a = t[k_split], b = t[(k_split + 1) % 3], c = t[(k_split + 2) % 3];
      put(a, m, c);
      put(m, b, c);
    }
  }
  faces.conservativeResize(3, nf);
  TriMesh mesh;
  mesh.x.resize(3, static_cast<Eigen::Index>(r.x.size()));
  for (std::size_t i = 0; i < r.x.size(); ++i) mesh.x.col(static_cast<Eigen::Index>(i)) = r.x[i];
  mesh.topo = build_topology(faces, static_cast<int>(mesh.x.cols()));
  return mesh;
}

void RefinedMeshOptions::validate() const {
  require_integer_in_range("continuum elements", target_elements, kMinContinuumElements,
                           kMaxContinuumElements);
  require_finite_in_range("mesh size ratio", "", size_ratio, 1.0, 10.0, Ends::closed_closed);
  require_finite_in_range("contact fraction", "", contact_fraction, 0.0, 0.5, Ends::open_open);
  require_finite_in_range("fine band", "fine sizes", band_fine_sizes, 0.0, 20.0,
                          Ends::closed_closed);
  require_finite_in_range("rim fine region", "fine sizes", rim_fine_sizes, 0.0, 20.0,
                          Ends::closed_closed);
  require_finite_in_range("mesh grading", "", grading, 0.0, 2.0, Ends::open_closed);
  require_integer_in_range("refinement levels", max_levels, 0, 10);
}

TriMesh make_refined_mesh(const RefinedMeshOptions& o, RefinedMeshReport* report) {
  o.validate();
  const EvansFungMeasures exact = evans_fung_measures(o.shape);
  RefinedSizeField field;
  field.plane_um = rest_contact_plane(o.shape, o.contact_fraction);
  field.rim_y_um = o.shape.radius_um;
  field.grading = o.grading;
  struct Trial {
    TriMesh mesh;
    RefinedSizeField field;
    int coarse_vertices = 0, coarse_elements = 0;
  };
  auto refine_on = [&](int frequency, unsigned rotation_seed) {
    RestShapeOptions ro;
    ro.shape = o.shape;
    ro.target_vertices = 10 * frequency * frequency + 2;
    ro.orientation = o.orientation;
    ro.rotation_seed = rotation_seed;
    ro.match_volume = false;  // the coarse vertices stay on the surface; matched at the end
    Trial t;
    const TriMesh coarse = make_rest_shape(ro);
    t.coarse_vertices = coarse.topo.num_vertices;
    t.coarse_elements = coarse.topo.num_faces();
    t.field = field;
    const double mean_edge_um = std::sqrt(4.0 / std::sqrt(3.0) * exact.area_um2 /
                                          static_cast<double>(coarse.topo.num_faces()));
    t.field.fine_um = mean_edge_um / o.size_ratio;
    t.field.band_um = o.band_fine_sizes * t.field.fine_um;
    t.field.rim_band_um = o.rim_fine_sizes * t.field.fine_um;
    t.mesh = refine_evans_fung_mesh(coarse, o.shape, t.field, o.max_levels);
    return t;
  };
  // Frequencies f with 10 f^2 + 2 vertices in make_rest_shape's range [100, 40000].
  static constexpr int kMinFrequency = 4, kMaxFrequency = 63;
  auto clamp_f = [](double f) {
    return std::clamp(static_cast<int>(std::lround(f)), kMinFrequency, kMaxFrequency);
  };
  // First guess: the refined count over the coarse count at the same frequency barely depends
  // on the frequency (the fine regions scale with the coarse size; measured 3 to 5 at size ratio
  // 2 to 3, grading 0.5), so f ~ sqrt(count).
  std::map<int, Trial> tried;
  int f = clamp_f(std::sqrt(o.target_elements / 20.0 / (1.0 + 1.5 * o.size_ratio)));
  int passes = 0;
  // The frequency is searched on the unturned icosphere, so that every turn of a request is a
  // turn of the same coarse mesh (a turned mesh's refined count differs from the unturned one's
  // by up to 9 % at f = 4 to 8, enough for its own search to land on another frequency: the
  // rotations of one row would then be triangulations of different sizes).
  for (; passes < 6 && !tried.count(f); ++passes) {
    tried.emplace(f, refine_on(f, 0));
    const double count = tried.at(f).mesh.topo.num_faces();
    const int scaled = clamp_f(f * std::sqrt(o.target_elements / count));
    // Jump by the count's scaling; once it points back to a tried frequency, bracket the
    // target by the neighbour on its side (the counts grow with f).
    const int neighbour = clamp_f(count > o.target_elements ? f - 1 : f + 1);
    f = !tried.count(scaled) ? scaled : neighbour;
  }
  // The closest count of the frequencies tried.
  const Trial* best = nullptr;
  int best_f = 0;
  for (const auto& [freq, t] : tried)
    if (!best || std::abs(t.mesh.topo.num_faces() - o.target_elements) <
                     std::abs(best->mesh.topo.num_faces() - o.target_elements)) {
      best = &t;
      best_f = freq;
    }
  Trial turned;
  if (o.seed != 0) {
    turned = refine_on(best_f, o.seed);
    best = &turned;
  }
  TriMesh mesh = best->mesh;
  double scale = 1.0;
  if (o.match_volume) {
    scale = std::cbrt(exact.volume_um3 / enclosed_volume(mesh.x, mesh.topo));
    mesh.x *= scale;  // the shape is centred at the origin
  }
  if (report) {
    report->size = best->field;
    report->coarse_vertices = best->coarse_vertices;
    report->coarse_elements = best->coarse_elements;
    report->passes = passes;
    report->vertices = mesh.topo.num_vertices;
    report->elements = mesh.topo.num_faces();
    report->volume_scale = scale;
  }
  return mesh;
}

}  // namespace rbc
