// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/reduced_hessian.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>

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
                                                   const SymmetryReduction& red)
    : model_(&model), stars_of_(make_vertex_stars(model.topo)) {
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
  const Topology& t = model_->topo;
  // Calls f(verts, count, weight, list) for every representative element, kind by kind.
  auto each_element = [&](auto&& f, Target* target) {
    for (const Element& e : faces_) {
      const std::array<int, 3> v{t.faces(0, e.id), t.faces(1, e.id), t.faces(2, e.id)};
      f(v.data(), 3, e.weight, target ? &target->faces : nullptr);
    }
    for (const Element& e : hinges_) {
      const std::array<int, 4> v{t.edges(0, e.id), t.edges(1, e.id), t.edge_opposite(0, e.id),
                                 t.edge_opposite(1, e.id)};
      f(v.data(), 4, e.weight, target ? &target->hinges : nullptr);
    }
    for (const Element& e : stars_)
      f(stars_of_.begin(e.id), stars_of_.size(e.id), e.weight, target ? &target->stars : nullptr);
  };
  // Calls f(ia, ib, ra, rb, a, b) for the local entries (a, b) of an element (full coordinates
  // ia, ib) that land on the reduced lower triangle (ra >= rb); ra == rb with a != b: both
  // orders count.
  auto each_entry = [&](const int* verts, int count, auto&& f) {
    const int n = 3 * count;
    if (n > 255)
      throw std::invalid_argument("reduced Hessian: a vertex star of " + std::to_string(count) +
                                  " vertices (at most 85 supported)");
    for (int b = 0; b < n; ++b) {
      const int ib = 3 * verts[b / 3] + b % 3, rb = red.reduced_index[ib];
      if (rb < 0) continue;
      for (int a = 0; a < n; ++a) {
        const int ia = 3 * verts[a / 3] + a % 3, ra = red.reduced_index[ia];
        if (ra >= rb) f(ia, ib, ra, rb, a, b);
      }
    }
  };
  // The reduced pattern: every entry a representative element reaches. The images of an
  // element reach the same reduced entries, so this is the pattern of P' d2L P (the same as
  // reducing the full Hessian's block pattern). Built from the pairs of orbits the elements
  // link (a few per element, not (3 x vertices)^2 entries): every free coordinate of one orbit
  // with every free coordinate of the other, lower triangle.
  std::vector<int> orbit(static_cast<size_t>(t.num_vertices), -1);  // -1: every coordinate pinned
  for (int v = 0; v < t.num_vertices; ++v)
    for (int k = 0; k < 3; ++k)
      if (const int r = red.reduced_index[3 * static_cast<size_t>(v) + k]; r >= 0)
        orbit[static_cast<size_t>(v)] = red.orbit_of_entry[static_cast<size_t>(r)];
  std::vector<std::uint64_t> links;  // (column orbit << 32) | row orbit, row orbit >= column's
  each_element(
      [&](const int* verts, int count, int, ScatterList*) {
        for (int a = 0; a < count; ++a)
          for (int b = 0; b < count; ++b) {
            const int oa = orbit[static_cast<size_t>(verts[a])];
            const int ob = orbit[static_cast<size_t>(verts[b])];
            if (oa >= ob && ob >= 0)
              links.push_back(static_cast<std::uint64_t>(ob) << 32 |
                              static_cast<std::uint32_t>(oa));
          }
      },
      nullptr);
  std::sort(links.begin(), links.end());
  links.erase(std::unique(links.begin(), links.end()), links.end());
  auto target = std::make_unique<Target>();
  Eigen::SparseMatrix<double>& m = target->matrix;
  m.resize(red.reduced_size, red.reduced_size);
  std::vector<int> outer(static_cast<size_t>(red.reduced_size) + 1, 0), inner;
  for (size_t l = 0; l < links.size();) {  // the links of one column orbit
    const int oc = static_cast<int>(links[l] >> 32);
    size_t end = l;
    while (end < links.size() && static_cast<int>(links[end] >> 32) == oc) ++end;
    for (int col = red.block_offset[oc]; col < red.block_offset[oc + 1]; ++col) {
      for (size_t k = l; k < end; ++k) {
        const int orow = static_cast<int>(links[k] & 0xffffffffu);
        for (int row = std::max(col, red.block_offset[orow]); row < red.block_offset[orow + 1];
             ++row)
          inner.push_back(row);
      }
      outer[static_cast<size_t>(col) + 1] = static_cast<int>(inner.size());
    }
    l = end;
  }
  for (size_t c = 1; c < outer.size(); ++c) outer[c] = std::max(outer[c], outer[c - 1]);
  m.resizeNonZeros(static_cast<Eigen::Index>(inner.size()));
  std::copy(outer.begin(), outer.end(), m.outerIndexPtr());
  std::copy(inner.begin(), inner.end(), m.innerIndexPtr());
  std::fill(m.valuePtr(), m.valuePtr() + inner.size(), 0.0);
  // Where entry (row, col) of the pattern lies, by arithmetic on the orbit links instead of a
  // search per entry (the sector set-up was 7 % of a mirror-planes sweep's process). Column col
  // of orbit oc holds, in order, the rows col .. block_offset[oc + 1] - 1 of its own orbit (the
  // diagonal link, which every element through the orbit makes) and then the whole row blocks
  // of its other linked orbits; link k's block starts `offset[k]` rows after the diagonal
  // block's end.
  std::vector<int> offset(links.size(), 0);
  for (size_t l = 0; l < links.size();) {
    const int oc = static_cast<int>(links[l] >> 32);
    int rows = 0;
    for (; l < links.size() && static_cast<int>(links[l] >> 32) == oc; ++l) {
      const int orow = static_cast<int>(links[l] & 0xffffffffu);
      if (orow == oc) continue;
      offset[l] = rows;
      rows += red.block_offset[orow + 1] - red.block_offset[orow];
    }
  }
  auto link_of = [&links](int ocol, int orow) {
    const std::uint64_t key =
        static_cast<std::uint64_t>(ocol) << 32 | static_cast<std::uint32_t>(orow);
    return static_cast<int>(std::lower_bound(links.begin(), links.end(), key) - links.begin());
  };
  auto value_index = [&](int row, int col, int link) {
    const int oc = red.orbit_of_entry[static_cast<size_t>(col)];
    const int orow = red.orbit_of_entry[static_cast<size_t>(row)];
    const int first = m.outerIndexPtr()[col];
    const int pos = orow == oc ? first + (row - col)
                               : first + (red.block_offset[oc + 1] - col) + offset[link] +
                                     (row - red.block_offset[orow]);
    // Both passes visit the same elements through the same orbits, so every entry is in the
    // pattern; a change that lets them drift apart must fail here, not scatter elsewhere.
    if (pos < first || pos >= m.outerIndexPtr()[col + 1] || m.innerIndexPtr()[pos] != row)
      throw std::logic_error("reduced Hessian: an element entry lies outside the pattern");
    return pos;
  };
  // The scatter lists, sized exactly by a counting pass (an upper bound left most of them
  // unused).
  size_t counts[3] = {0, 0, 0};
  each_element(
      [&](const int* verts, int count, int, ScatterList* list) {
        const size_t kind = list == &target->faces ? 0 : list == &target->hinges ? 1 : 2;
        each_entry(verts, count, [&](int, int, int, int, int, int) { ++counts[kind]; });
      },
      target.get());
  target->faces.entries.reserve(counts[0]);
  target->hinges.entries.reserve(counts[1]);
  target->stars.entries.reserve(counts[2]);
  std::vector<int> pair_link;  // per pair of the element's vertices: its link (column, row orbit)
  each_element(
      [&](const int* verts, int count, int weight, ScatterList* list) {
        pair_link.assign(static_cast<size_t>(count) * static_cast<size_t>(count), -1);
        for (int a = 0; a < count; ++a)
          for (int b = 0; b < count; ++b) {
            const int oa = orbit[static_cast<size_t>(verts[a])];
            const int ob = orbit[static_cast<size_t>(verts[b])];
            if (oa > ob && ob >= 0) pair_link[static_cast<size_t>(a * count + b)] = link_of(ob, oa);
          }
        each_entry(verts, count, [&](int ia, int ib, int ra, int rb, int a, int b) {
          const int link = pair_link[static_cast<size_t>((a / 3) * count + b / 3)];
          list->entries.push_back(Scatter{
              value_index(ra, rb, link), static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(b),
              static_cast<std::int16_t>(weight * red.sign[ia] * red.sign[ib])});
        });
        list->begin.push_back(static_cast<int>(list->entries.size()));
      },
      target.get());
  targets_.push_back(std::move(target));
}

int ReducedLagrangianHessian::add_sector(const SymmetryReduction& sector_reduction) {
  add_target(sector_reduction);
  return sectors() - 1;
}

void ReducedLagrangianHessian::element_matrices(const Positions& x, double area_coef,
                                                double volume_coef) {
  const Topology& t = model_->topo;
  const JuelicherHessianTerms terms = juelicher_hessian_terms(x, t, model_->bending);
  const int nf = static_cast<int>(faces_.size()), ne = static_cast<int>(hinges_.size()),
            nv = static_cast<int>(stars_.size());
  // Element matrices (the cost) on the threads; the scatter in a fixed order (the matrix does
  // not depend on the thread count).
  constexpr int kParallelHessianElements = 256;
#pragma omp parallel if (nf > kParallelHessianElements && omp_get_max_threads() > 1)
  {
#pragma omp for schedule(static) nowait
    for (int k = 0; k < nf; ++k)
      lagrangian_face_hessian(*model_, x, terms, faces_[k].id, area_coef, volume_coef,
                              face_buffer_[k]);
#pragma omp for schedule(static) nowait
    for (int k = 0; k < ne; ++k)
      lagrangian_hinge_hessian(*model_, x, terms, hinges_[k].id, hinge_buffer_[k]);
#pragma omp for schedule(static)
    for (int k = 0; k < nv; ++k) {
      std::vector<double>& u = star_buffer_[k];
      terms.cell_gradient(t, stars_of_, stars_[k].id, u.data());
      u.back() = terms.cell_weight(stars_[k].id);
    }
  }
}

void ReducedLagrangianHessian::scatter(Target& target) {
  Eigen::SparseMatrix<double>& out = target.matrix;
  double* v = out.valuePtr();
  std::fill(v, v + out.nonZeros(), 0.0);
  const auto each = [](const ScatterList& list, size_t k) {
    return std::pair(list.entries.data() + list.begin[k], list.entries.data() + list.begin[k + 1]);
  };
  for (size_t k = 0; k < faces_.size(); ++k)
    for (auto [s, end] = each(target.faces, k); s != end; ++s)
      v[s->value] += s->coef * face_buffer_[k](s->a, s->b);
  for (size_t k = 0; k < hinges_.size(); ++k)
    for (auto [s, end] = each(target.hinges, k); s != end; ++s)
      v[s->value] += s->coef * hinge_buffer_[k](s->a, s->b);
  for (size_t k = 0; k < stars_.size(); ++k) {
    const std::vector<double>& u = star_buffer_[k];
    const double c = u.back();
    for (auto [s, end] = each(target.stars, k); s != end; ++s)
      v[s->value] += s->coef * c * u[s->a] * u[s->b];
  }
}

const Eigen::SparseMatrix<double>& ReducedLagrangianHessian::assemble(const Positions& x,
                                                                      double area_coef,
                                                                      double volume_coef) {
  element_matrices(x, area_coef, volume_coef);
  scatter(*targets_[0]);
  return targets_[0]->matrix;
}

void ReducedLagrangianHessian::assemble_sectors(const Positions& x, double area_coef,
                                                double volume_coef) {
  element_matrices(x, area_coef, volume_coef);
  for (size_t k = 1; k < targets_.size(); ++k) scatter(*targets_[k]);
}

}  // namespace rbc
