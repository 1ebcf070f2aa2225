// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/block_hessian.hpp"

#include <vector>

namespace rbc {
namespace {

std::vector<std::vector<int>> closed_star_columns(const Topology& topo, BlockStorage storage) {
  const int n = topo.num_vertices;
  std::vector<std::vector<int>> cols(n);
  std::vector<int> star;
  for (int v = 0; v < n; ++v) {
    star.assign(1, v);
    star.insert(star.end(), topo.vertex_neighbours.begin(v), topo.vertex_neighbours.end(v));
    for (int a : star)
      for (int b : star)
        if (storage == BlockStorage::full || a >= b) cols[b].push_back(a);
  }
  return cols;
}

}  // namespace

int BlockHessian::local_code(int i, int j) const {
  if (storage() == BlockStorage::lower && i < j) return -1;  // its transpose (j, i) is added
  return block_code(i, j);
}

BlockHessian::BlockHessian(const Topology& topo, BlockStorage storage)
    : BlockMatrix(closed_star_columns(topo, storage), storage), stars_(make_vertex_stars(topo)) {
  const int nf = topo.num_faces(), ne = topo.num_edges(), nv = topo.num_vertices;
  face_codes_.resize(9 * static_cast<size_t>(nf));
  for (int f = 0; f < nf; ++f)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        face_codes_[9 * f + 3 * a + b] = local_code(topo.faces(a, f), topo.faces(b, f));
  hinge_codes_.resize(16 * static_cast<size_t>(ne));
  for (int e = 0; e < ne; ++e) {
    const int v[4] = {topo.edges(0, e), topo.edges(1, e), topo.edge_opposite(0, e),
                      topo.edge_opposite(1, e)};
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) hinge_codes_[16 * e + 4 * a + b] = local_code(v[a], v[b]);
  }
  star_code_offsets_.assign(nv + 1, 0);
  for (int v = 0; v < nv; ++v) {
    const int s = stars_.size(v);
    star_code_offsets_[v + 1] = star_code_offsets_[v] + s * s;
    for (int a = 0; a < s; ++a)
      for (int b = 0; b < s; ++b)
        star_codes_.push_back(local_code(stars_.begin(v)[a], stars_.begin(v)[b]));
  }
}

void BlockHessian::add_star_outer(int v, const double* u, double coef) {
  const int s = stars_.size(v);
  const int* codes = star_codes_.data() + star_code_offsets_[v];
  for (int a = 0; a < s; ++a) {
    const Eigen::Map<const Eigen::Vector3d> ua(u + 3 * a);
    for (int b = 0; b < s; ++b)
      if (codes[s * a + b] >= 0)
        add(codes[s * a + b],
            Eigen::Matrix3d(coef * ua * Eigen::Map<const Eigen::Vector3d>(u + 3 * b).transpose()));
  }
}

BlockHessian::ElementBuffers& BlockHessian::element_buffers() {
  const size_t nf = face_codes_.size() / 9, ne = hinge_codes_.size() / 16;
  const size_t nv = star_code_offsets_.size() - 1;
  buffers_.faces.resize(nf);
  buffers_.hinges.resize(ne);
  buffers_.star_vectors.resize(3 * stars_.vertices.size());
  buffers_.star_coefs.resize(nv);
  return buffers_;
}

void BlockHessian::add_elements_share(const ElementBuffers& b, int part, int parts) {
  // Stored blocks [lo, hi) belong to this share; a code c addresses block c >> 1.
  const long long nb = num_blocks();
  const int lo = static_cast<int>(nb * part / parts),
            hi = static_cast<int>(nb * (part + 1) / parts);
  const auto mine = [lo, hi](int code) {
    return code >= 0 && (code >> 1) >= lo && (code >> 1) < hi;
  };
  const int nf = static_cast<int>(b.faces.size()), ne = static_cast<int>(b.hinges.size());
  for (int f = 0; f < nf; ++f) {
    const int* codes = &face_codes_[9 * f];
    for (int k = 0; k < 9; ++k)
      if (mine(codes[k])) add(codes[k], b.faces[f].block<3, 3>(3 * (k / 3), 3 * (k % 3)));
  }
  for (int e = 0; e < ne; ++e) {
    const int* codes = &hinge_codes_[16 * e];
    for (int k = 0; k < 16; ++k)
      if (mine(codes[k])) add(codes[k], b.hinges[e].block<3, 3>(3 * (k / 4), 3 * (k % 4)));
  }
  const int nv = static_cast<int>(b.star_coefs.size());
  for (int v = 0; v < nv; ++v) {
    const int s = stars_.size(v);
    const int* codes = star_codes_.data() + star_code_offsets_[v];
    const double* u = b.star_vectors.data() + star_vector_offset(v);
    const double coef = b.star_coefs[v];
    for (int a = 0; a < s; ++a) {
      const Eigen::Map<const Eigen::Vector3d> ua(u + 3 * a);
      for (int c = 0; c < s; ++c)
        if (mine(codes[s * a + c]))
          add(codes[s * a + c],
              Eigen::Matrix3d(coef * ua *
                              Eigen::Map<const Eigen::Vector3d>(u + 3 * c).transpose()));
    }
  }
}

}  // namespace rbc
