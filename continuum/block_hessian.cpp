#include "continuum/block_hessian.hpp"

#include <algorithm>
#include <cassert>

namespace rbc {

BlockHessian::BlockHessian(const Topology& topo) {
  const int n = topo.num_vertices;
  std::vector<std::vector<int>> cols(n);
  std::vector<int> star;
  for (int v = 0; v < n; ++v) {
    star.assign(1, v);
    star.insert(star.end(), topo.vertex_neighbours.begin(v), topo.vertex_neighbours.end(v));
    for (int a : star)
      for (int b : star) cols[b].push_back(a);
  }
  BlockPattern p = make_block_pattern(std::move(cols));
  offsets_ = std::move(p.col_offsets);
  rows_ = std::move(p.rows);
  m_ = std::move(p.matrix);
}

void BlockHessian::set_zero() {
  std::fill(m_.valuePtr(), m_.valuePtr() + m_.nonZeros(), 0.0);
}

int BlockHessian::position(int i, int j) const {
  const auto first = rows_.begin() + offsets_[j], last = rows_.begin() + offsets_[j + 1];
  const auto it = std::lower_bound(first, last, i);
  assert(it != last && *it == i && "block outside the Hessian pattern");
  return static_cast<int>(it - first);
}

void BlockHessian::add_block(int i, int j, const Eigen::Matrix3d& b) {
  const int k = position(i, j);
  double* values = m_.valuePtr();
  const int* outer = m_.outerIndexPtr();
  for (int c = 0; c < 3; ++c) {
    double* col = values + outer[3 * j + c] + 3 * k;
    for (int r = 0; r < 3; ++r) col[r] += b(r, c);
  }
}

void BlockHessian::add_outer(const std::vector<int>& verts, const Eigen::VectorXd& u, double coef) {
  const int k = static_cast<int>(verts.size());
  for (int a = 0; a < k; ++a)
    for (int b = 0; b < k; ++b)
      add_block(verts[a], verts[b], coef * u.segment<3>(3 * a) * u.segment<3>(3 * b).transpose());
}

}  // namespace rbc
