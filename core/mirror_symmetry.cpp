// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/mirror_symmetry.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace rbc {

std::string to_string(Symmetry s) {
  return s == Symmetry::mirror ? "mirror" : "none";
}

Symmetry symmetry_from_string(const std::string& name) {
  if (name == "none") return Symmetry::none;
  if (name == "mirror") return Symmetry::mirror;
  throw std::invalid_argument("symmetry '" + name + "' is not one of none, mirror");
}

namespace {

/// The largest subgroup among a set of elements found one by one within a tolerance (masks
/// under XOR; element 0, the identity, first). Each element passes its own test, so near the
/// tolerance the set need not be closed: e.g. 6 of the 8 reflections of a mesh that Phi
/// minimisation left 1e-8 um off symmetric. The reductions need a group. Of equally large
/// subgroups the one whose element-index bit set is smallest is kept (deterministic); a closed
/// input comes back unchanged (elements, order and images).
MeshSymmetry largest_subgroup(MeshSymmetry s) {
  const int n = s.order();
  if (n < 1 || n > 8 || s.reflections[0] != 0)
    throw std::logic_error("mirror symmetry: the elements must start with the identity (1 to 8)");
  int best = 1;  // subset of s's element indices, as a bit set (bit 0: the identity)
  for (int subset = 1; subset < (1 << n); subset += 2) {  // always with the identity
    if (__builtin_popcount(static_cast<unsigned>(subset)) <=
        __builtin_popcount(static_cast<unsigned>(best)))
      continue;
    unsigned masks = 0;  // the subset's elements as a set of masks
    for (int k = 0; k < n; ++k)
      if (subset >> k & 1) masks |= 1u << s.reflections[static_cast<size_t>(k)];
    bool closed = true;
    for (int a = 0; a < 8 && closed; ++a)
      for (int b = 0; b < 8 && closed; ++b)
        if ((masks >> a & 1) && (masks >> b & 1)) closed = masks >> (a ^ b) & 1;
    if (closed) best = subset;
  }
  MeshSymmetry out;
  out.reflections.clear();
  for (int k = 0; k < n; ++k)
    if (best >> k & 1) {
      out.reflections.push_back(s.reflections[static_cast<size_t>(k)]);
      out.image.push_back(std::move(s.image[static_cast<size_t>(k)]));
    }
  return out;
}

}  // namespace

MeshSymmetry find_mirror_symmetry(const Positions& x, const Topology& topo, double tolerance_um) {
  if (!(tolerance_um >= 0) || !std::isfinite(tolerance_um))
    throw std::invalid_argument("mirror tolerance must be finite and >= 0 um, got " +
                                std::to_string(tolerance_um));
  const int n = static_cast<int>(x.cols());
  if (n != topo.num_vertices)
    throw std::invalid_argument("find_mirror_symmetry: positions and topology disagree");
  MeshSymmetry sym;
  sym.image.emplace_back(n);
  std::iota(sym.image[0].begin(), sym.image[0].end(), 0);
  // Vertices sorted by x: an image is looked up among those within the tolerance in x.
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return x(0, a) < x(0, b) || (x(0, a) == x(0, b) && a < b); });
  std::vector<double> sorted_x(n);
  for (int k = 0; k < n; ++k) sorted_x[k] = x(0, order[k]);
  auto match = [&](const Eigen::Vector3d& p) {
    auto it = std::lower_bound(sorted_x.begin(), sorted_x.end(), p(0) - tolerance_um);
    for (auto k = it - sorted_x.begin(); k < n && sorted_x[k] <= p(0) + tolerance_um; ++k)
      if ((x.col(order[k]) - p).norm() <= tolerance_um) return order[k];
    return -1;
  };
  // Faces as sorted vertex triples (a reflection reverses their orientation).
  auto sorted_face = [](int a, int b, int c) {
    std::array<int, 3> t{a, b, c};
    std::sort(t.begin(), t.end());
    return t;
  };
  std::vector<std::array<int, 3>> faces;
  faces.reserve(topo.num_faces());
  for (int f = 0; f < topo.num_faces(); ++f)
    faces.push_back(sorted_face(topo.faces(0, f), topo.faces(1, f), topo.faces(2, f)));
  std::sort(faces.begin(), faces.end());
  for (int mask = 1; mask < 8; ++mask) {
    const Eigen::Vector3d s(reflection_sign(mask, 0), reflection_sign(mask, 1),
                            reflection_sign(mask, 2));
    std::vector<int> image(n);
    std::vector<char> hit(n, 0);
    bool ok = true;
    for (int i = 0; i < n && ok; ++i) {
      const int j = match(x.col(i).cwiseProduct(s));
      ok = j >= 0 && !hit[j];
      if (ok) {
        image[i] = j;
        hit[j] = 1;
      }
    }
    for (int f = 0; f < topo.num_faces() && ok; ++f)
      ok = std::binary_search(
          faces.begin(), faces.end(),
          sorted_face(image[topo.faces(0, f)], image[topo.faces(1, f)], image[topo.faces(2, f)]));
    if (!ok) continue;
    sym.reflections.push_back(mask);
    sym.image.push_back(std::move(image));
  }
  return largest_subgroup(std::move(sym));
}

MeshSymmetry keep_invariant(const MeshSymmetry& symmetry, const std::vector<int>& vertices,
                            const std::vector<double>& w, int sign_coordinate, double tolerance) {
  if (vertices.size() != w.size())
    throw std::invalid_argument("keep_invariant: one value per listed vertex needed");
  const size_t n = symmetry.image.empty() ? 0 : symmetry.image[0].size();
  std::vector<double> dense(n, 0.0);
  for (size_t k = 0; k < vertices.size(); ++k) dense.at(static_cast<size_t>(vertices[k])) += w[k];
  MeshSymmetry out;
  out.reflections.clear();
  for (int g = 0; g < symmetry.order(); ++g) {
    const double s = reflection_sign(symmetry.reflections[g], sign_coordinate);
    bool ok = true;
    for (size_t i = 0; i < n && ok; ++i)
      ok = std::abs(dense[static_cast<size_t>(symmetry.image[g][i])] - s * dense[i]) <= tolerance;
    if (!ok) continue;
    out.reflections.push_back(symmetry.reflections[g]);
    out.image.push_back(symmetry.image[g]);
  }
  return largest_subgroup(std::move(out));
}

std::vector<int> nontrivial_characters(const MeshSymmetry& sym) {
  // Characters of a subgroup of (Z2)^3 are the masks c restricted to it; two masks that agree
  // on every element give the same character.
  std::vector<std::vector<double>> seen{std::vector<double>(sym.reflections.size(), 1.0)};
  std::vector<int> out;
  for (int c = 1; c < 8; ++c) {
    std::vector<double> values;
    for (int g : sym.reflections) values.push_back(character_value(c, g));
    if (std::find(seen.begin(), seen.end(), values) != seen.end()) continue;
    seen.push_back(values);
    out.push_back(c);
  }
  return out;
}

SymmetryReduction make_symmetry_reduction(const MeshSymmetry& sym, int character) {
  if (sym.image.empty() || sym.reflections.empty() || sym.reflections[0] != 0)
    throw std::invalid_argument("make_symmetry_reduction: the identity must come first");
  const int n = static_cast<int>(sym.image[0].size());
  SymmetryReduction r;
  r.group_order = sym.order();
  r.full_size = 3 * n;
  r.reduced_index.assign(3 * static_cast<size_t>(n), -1);
  r.sign.assign(3 * static_cast<size_t>(n), 1.0);
  std::vector<char> seen(n, 0);
  int next = 0;
  r.block_offset.push_back(0);
  for (int i = 0; i < n; ++i) {
    if (seen[i]) continue;
    const int orbit = static_cast<int>(r.representative.size());
    // Free coordinates: those every element h of i's stabiliser leaves unchanged (times the
    // character: chi(h) s_k(h) = +1).
    bool free_k[3] = {true, true, true};
    for (int g = 0; g < sym.order(); ++g)
      if (sym.image[g][i] == i)
        for (int k = 0; k < 3; ++k)
          free_k[k] = free_k[k] && character_value(character, sym.reflections[g]) *
                                           reflection_sign(sym.reflections[g], k) >
                                       0;
    int index[3] = {-1, -1, -1};
    for (int k = 0; k < 3; ++k)
      if (free_k[k]) {
        index[k] = next++;
        r.orbit_of_entry.push_back(orbit);
      }
    int size = 0;
    for (int g = 0; g < sym.order(); ++g) {
      const int j = sym.image[g][i];
      if (seen[j]) continue;  // reached by an earlier element (same signs on free coordinates)
      seen[j] = 1;
      ++size;
      for (int k = 0; k < 3; ++k) {
        r.reduced_index[3 * static_cast<size_t>(j) + k] = index[k];
        r.sign[3 * static_cast<size_t>(j) + k] =
            character_value(character, sym.reflections[g]) * reflection_sign(sym.reflections[g], k);
      }
    }
    r.representative.push_back(i);
    r.orbit_size.push_back(size);
    r.block_offset.push_back(next);
  }
  r.reduced_size = next;
  return r;
}

Eigen::VectorXd expand(const SymmetryReduction& r, const Eigen::VectorXd& q) {
  Eigen::VectorXd x(r.full_size);
  for (int i = 0; i < r.full_size; ++i) {
    const int a = r.reduced_index[i];
    x(i) = a >= 0 ? r.sign[i] * q(a) : 0.0;
  }
  return x;
}

Eigen::VectorXd symmetric_part(const SymmetryReduction& r, const Eigen::VectorXd& x) {
  Eigen::VectorXd q = reduce(r, x);
  for (int a = 0; a < r.reduced_size; ++a) q(a) /= r.orbit_size[r.orbit_of_entry[a]];
  return q;
}

Eigen::VectorXd reduce(const SymmetryReduction& r, const Eigen::VectorXd& v) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(r.reduced_size);
  for (int i = 0; i < r.full_size; ++i) {
    const int a = r.reduced_index[i];
    if (a >= 0) q(a) += r.sign[i] * v(i);
  }
  return q;
}

Eigen::MatrixXd reduce(const SymmetryReduction& r, const Eigen::MatrixXd& v) {
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(r.reduced_size, v.cols());
  for (Eigen::Index c = 0; c < v.cols(); ++c) q.col(c) = reduce(r, Eigen::VectorXd(v.col(c)));
  return q;
}

double largest_vertex_norm_of_reduced(const SymmetryReduction& r, const Eigen::VectorXd& gq) {
  double largest = 0.0;
  for (size_t o = 0; o < r.representative.size(); ++o) {
    const int b = r.block_offset[o], e = r.block_offset[o + 1];
    largest = std::max(largest, gq.segment(b, e - b).norm() / r.orbit_size[o]);
  }
  return largest;
}

double largest_vertex_norm_of_expanded(const SymmetryReduction& r, const Eigen::VectorXd& dq) {
  double largest = 0.0;
  for (size_t o = 0; o < r.representative.size(); ++o) {
    const int b = r.block_offset[o], e = r.block_offset[o + 1];
    largest = std::max(largest, dq.segment(b, e - b).norm());
  }
  return largest;
}

ReducedMatrix::ReducedMatrix(const SymmetryReduction& red, const Eigen::SparseMatrix<double>& h)
    : rows_(h.rows()), nonzeros_(h.nonZeros()) {
  if (h.rows() != red.full_size || h.cols() != red.full_size || !h.isCompressed())
    throw std::invalid_argument("ReducedMatrix: a compressed 3N x 3N matrix is needed");
  // Pass 1: the pattern of P' H P (lower triangle), from H's lower triangle.
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(static_cast<size_t>(h.nonZeros()));
  for (Eigen::Index c = 0; c < h.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(h, c); it; ++it) {
      if (it.row() < c) continue;
      const int a = red.reduced_index[it.row()], b = red.reduced_index[c];
      if (a >= 0 && b >= 0) entries.emplace_back(std::max(a, b), std::min(a, b), 0.0);
    }
  out_.resize(red.reduced_size, red.reduced_size);
  out_.setFromTriplets(entries.begin(), entries.end());
  out_.makeCompressed();
  // Pass 2: where each value of H goes. An off-diagonal entry of H (stored once, standing for
  // both (i, j) and (j, i)) whose two coordinates share one reduced coordinate adds twice to
  // that diagonal entry.
  target_.assign(static_cast<size_t>(h.nonZeros()), -1);
  coef_.assign(static_cast<size_t>(h.nonZeros()), 0.0);
  for (Eigen::Index c = 0; c < h.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(h, c); it; ++it) {
      if (it.row() < c) continue;
      const int a = red.reduced_index[it.row()], b = red.reduced_index[c];
      if (a < 0 || b < 0) continue;
      const int row = std::max(a, b), col = std::min(a, b);
      const int* begin = out_.innerIndexPtr() + out_.outerIndexPtr()[col];
      const int* end = out_.innerIndexPtr() + out_.outerIndexPtr()[col + 1];
      const int* pos = std::lower_bound(begin, end, row);
      const auto k = static_cast<size_t>(&it.valueRef() - h.valuePtr());
      target_[k] = static_cast<int>(pos - out_.innerIndexPtr());
      coef_[k] = red.sign[it.row()] * red.sign[c] * (it.row() != c && a == b ? 2.0 : 1.0);
    }
}

const Eigen::SparseMatrix<double>& ReducedMatrix::reduce(const Eigen::SparseMatrix<double>& h) {
  if (!matches(h)) throw std::logic_error("ReducedMatrix: the matrix's pattern changed");
  double* out = out_.valuePtr();
  std::fill(out, out + out_.nonZeros(), 0.0);
  const double* v = h.valuePtr();
  for (size_t k = 0; k < target_.size(); ++k)
    if (target_[k] >= 0) out[target_[k]] += coef_[k] * v[k];
  return out_;
}

}  // namespace rbc
