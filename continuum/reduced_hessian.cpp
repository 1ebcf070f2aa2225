#include "continuum/reduced_hessian.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <stdexcept>

namespace rbc {

namespace {

/// For elements given by their vertex sets (sorted), the orbit of each under the group: its
/// smallest member is the representative, the number of distinct members the weight.
/// Returns (representative id, weight) pairs, in id order.
template <size_t K>
std::vector<std::pair<int, int>> representatives(const MeshSymmetry& g,
                                                 const std::vector<std::array<int, K>>& sets) {
  std::vector<std::pair<std::array<int, K>, int>> index;
  index.reserve(sets.size());
  for (size_t e = 0; e < sets.size(); ++e) index.emplace_back(sets[e], static_cast<int>(e));
  std::sort(index.begin(), index.end());
  auto find = [&](const std::array<int, K>& key) {
    auto it = std::lower_bound(index.begin(), index.end(), std::make_pair(key, -1));
    if (it == index.end() || it->first != key)
      throw std::logic_error("reduced Hessian: an element's mirror image is not an element");
    return it->second;
  };
  std::vector<std::pair<int, int>> out;
  for (size_t e = 0; e < sets.size(); ++e) {
    std::vector<int> images;
    for (int k = 0; k < g.order(); ++k) {
      std::array<int, K> image;
      for (size_t q = 0; q < K; ++q) image[q] = g.image[k][sets[e][q]];
      std::sort(image.begin(), image.end());
      images.push_back(find(image));
    }
    std::sort(images.begin(), images.end());
    images.erase(std::unique(images.begin(), images.end()), images.end());
    if (images.front() == static_cast<int>(e))
      out.emplace_back(static_cast<int>(e), static_cast<int>(images.size()));
  }
  return out;
}

}  // namespace

ReducedLagrangianHessian::ReducedLagrangianHessian(const ContinuumModel& model,
                                                   const MeshSymmetry& group,
                                                   const SymmetryReduction& red,
                                                   const BlockHessian& full)
    : model_(model), stars_of_(full.stars()), full_pattern_(full.matrix()) {
  const Topology& t = model.topo;
  if (red.full_size != 3 * t.num_vertices || group.order() != red.group_order)
    throw std::invalid_argument("reduced Hessian: the reduction is not of this model's group");
  std::vector<std::array<int, 3>> face_sets(t.num_faces());
  for (int f = 0; f < t.num_faces(); ++f) {
    face_sets[f] = {t.faces(0, f), t.faces(1, f), t.faces(2, f)};
    std::sort(face_sets[f].begin(), face_sets[f].end());
  }
  for (const auto& [f, w] : representatives(group, face_sets)) faces_.push_back({f, w});
  std::vector<std::array<int, 2>> edge_sets(t.num_edges());
  for (int e = 0; e < t.num_edges(); ++e) edge_sets[e] = {t.edges(0, e), t.edges(1, e)};
  for (const auto& [e, w] : representatives(group, edge_sets)) hinges_.push_back({e, w});
  for (size_t o = 0; o < red.representative.size(); ++o)
    stars_.push_back({red.representative[o], red.orbit_size[o]});
  face_buffer_.resize(faces_.size());
  hinge_buffer_.resize(hinges_.size());
  star_buffer_.resize(stars_.size());
  for (size_t k = 0; k < stars_.size(); ++k)
    star_buffer_[k].resize(3 * static_cast<size_t>(stars_of_.size(stars_[k].id)) + 1);
  add_target(red);
}

void ReducedLagrangianHessian::add_target(const SymmetryReduction& red) {
  Target target{ReducedMatrix(red, full_pattern_), {}, {}, {}};
  // Scatter of a representative element with local vertices `verts` and orbit weight w.
  auto element = [&](const std::vector<int>& verts, int weight) {
    std::vector<Scatter> out;
    const int n = 3 * static_cast<int>(verts.size());
    for (int b = 0; b < n; ++b) {
      const int ib = 3 * verts[b / 3] + b % 3, rb = red.reduced_index[ib];
      if (rb < 0) continue;
      for (int a = 0; a < n; ++a) {
        const int ia = 3 * verts[a / 3] + a % 3, ra = red.reduced_index[ia];
        if (ra < rb) continue;  // lower triangle; ra == rb, a != b: both orders count
        const int v = target.map.value_index(ra, rb);
        if (v < 0) throw std::logic_error("reduced Hessian: an element lies outside the pattern");
        out.push_back(Scatter{v, static_cast<short>(a), static_cast<short>(b),
                              weight * red.sign[ia] * red.sign[ib]});
      }
    }
    return out;
  };
  const Topology& t = model_.topo;
  for (const Element& f : faces_)
    target.faces.push_back(
        element({t.faces(0, f.id), t.faces(1, f.id), t.faces(2, f.id)}, f.weight));
  for (const Element& e : hinges_)
    target.hinges.push_back(element(
        {t.edges(0, e.id), t.edges(1, e.id), t.edge_opposite(0, e.id), t.edge_opposite(1, e.id)},
        e.weight));
  for (const Element& v : stars_)
    target.stars.push_back(element(
        std::vector<int>(stars_of_.begin(v.id), stars_of_.begin(v.id) + stars_of_.size(v.id)),
        v.weight));
  targets_.push_back(std::move(target));
}

int ReducedLagrangianHessian::add_sector(const SymmetryReduction& sector_reduction) {
  add_target(sector_reduction);
  return sectors() - 1;
}

void ReducedLagrangianHessian::element_matrices(const Positions& x, double area_coef,
                                                double volume_coef) {
  const Topology& t = model_.topo;
  const JuelicherHessianTerms terms = juelicher_hessian_terms(x, t, model_.bending);
  const int nf = static_cast<int>(faces_.size()), ne = static_cast<int>(hinges_.size()),
            nv = static_cast<int>(stars_.size());
  // Element matrices (the cost) on the threads; the scatter in a fixed order (the matrix does
  // not depend on the thread count).
  constexpr int kParallelHessianElements = 256;
#pragma omp parallel if (nf > kParallelHessianElements && omp_get_max_threads() > 1)
  {
#pragma omp for schedule(static) nowait
    for (int k = 0; k < nf; ++k)
      lagrangian_face_hessian(model_, x, terms, faces_[k].id, area_coef, volume_coef,
                              face_buffer_[k]);
#pragma omp for schedule(static) nowait
    for (int k = 0; k < ne; ++k)
      lagrangian_hinge_hessian(model_, x, terms, hinges_[k].id, hinge_buffer_[k]);
#pragma omp for schedule(static)
    for (int k = 0; k < nv; ++k) {
      std::vector<double>& u = star_buffer_[k];
      terms.cell_gradient(t, stars_of_, stars_[k].id, u.data());
      u.back() = terms.cell_weight(stars_[k].id);
    }
  }
}

void ReducedLagrangianHessian::scatter(Target& target) {
  Eigen::SparseMatrix<double>& out = target.map.result();
  double* v = out.valuePtr();
  std::fill(v, v + out.nonZeros(), 0.0);
  for (size_t k = 0; k < faces_.size(); ++k)
    for (const Scatter& s : target.faces[k]) v[s.value] += s.coef * face_buffer_[k](s.a, s.b);
  for (size_t k = 0; k < hinges_.size(); ++k)
    for (const Scatter& s : target.hinges[k]) v[s.value] += s.coef * hinge_buffer_[k](s.a, s.b);
  for (size_t k = 0; k < stars_.size(); ++k) {
    const std::vector<double>& u = star_buffer_[k];
    const double c = u.back();
    for (const Scatter& s : target.stars[k]) v[s.value] += s.coef * c * u[s.a] * u[s.b];
  }
}

const Eigen::SparseMatrix<double>& ReducedLagrangianHessian::assemble(const Positions& x,
                                                                      double area_coef,
                                                                      double volume_coef) {
  element_matrices(x, area_coef, volume_coef);
  scatter(targets_[0]);
  return targets_[0].map.result();
}

void ReducedLagrangianHessian::assemble_sectors(const Positions& x, double area_coef,
                                                double volume_coef) {
  element_matrices(x, area_coef, volume_coef);
  for (size_t k = 1; k < targets_.size(); ++k) scatter(targets_[k]);
}

}  // namespace rbc
