// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/block_pattern.hpp"

#include <algorithm>
#include <cassert>
#include <stdexcept>

namespace rbc {

BlockPattern make_block_pattern(std::vector<std::vector<int>> cols) {
  const int n = static_cast<int>(cols.size());
  BlockPattern p;
  p.col_offsets.assign(n + 1, 0);
  for (int j = 0; j < n; ++j) {
    std::sort(cols[j].begin(), cols[j].end());
    cols[j].erase(std::unique(cols[j].begin(), cols[j].end()), cols[j].end());
    p.col_offsets[j + 1] = p.col_offsets[j] + static_cast<int>(cols[j].size());
  }
  p.rows.reserve(p.col_offsets[n]);
  for (int j = 0; j < n; ++j) p.rows.insert(p.rows.end(), cols[j].begin(), cols[j].end());

  p.matrix.resize(3 * n, 3 * n);
  // An empty pattern (a placeholder before the real one is built) stays an empty compressed
  // matrix: Eigen's reserve() + makeCompressed() read past the outer index of a 0 x 0 matrix.
  if (n == 0) return p;
  Eigen::VectorXi nnz(3 * n);
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 3; ++c) nnz(3 * j + c) = 3 * (p.col_offsets[j + 1] - p.col_offsets[j]);
  p.matrix.reserve(nnz);
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 3; ++c)
      for (int k = p.col_offsets[j]; k < p.col_offsets[j + 1]; ++k)
        for (int r = 0; r < 3; ++r) p.matrix.insert(3 * p.rows[k] + r, 3 * j + c) = 0.0;
  p.matrix.makeCompressed();
  return p;
}

BlockMatrix::BlockMatrix(std::vector<std::vector<int>> cols, BlockStorage storage)
    : storage_(storage) {
  const int n = static_cast<int>(cols.size());
  for (int j = 0; j < n; ++j) cols[j].push_back(j);  // the diagonal is always stored
  BlockPattern p = make_block_pattern(std::move(cols));
  col_offsets_ = std::move(p.col_offsets);
  rows_ = std::move(p.rows);
  m_ = std::move(p.matrix);
  start_.resize(rows_.size());
  stride_.resize(rows_.size());
  diagonal_.resize(n);
  for (int j = 0; j < n; ++j) {
    const int len = col_offsets_[j + 1] - col_offsets_[j];
    for (int k = col_offsets_[j]; k < col_offsets_[j + 1]; ++k) {
      if (storage_ == BlockStorage::lower && rows_[k] < j)
        throw std::logic_error("block pattern: lower storage lists a block above the diagonal");
      start_[k] = m_.outerIndexPtr()[3 * j] + 3 * (k - col_offsets_[j]);
      stride_[k] = 3 * len;
      if (rows_[k] == j) diagonal_[j] = k;
    }
  }
}

int BlockMatrix::block_code(int i, int j) const {
  const bool transposed = storage_ == BlockStorage::lower && i < j;
  if (transposed) std::swap(i, j);
  const auto first = rows_.begin() + col_offsets_[j];
  const auto last = rows_.begin() + col_offsets_[j + 1];
  const auto it = std::lower_bound(first, last, i);
  if (it == last || *it != i) return -1;
  return 2 * static_cast<int>(it - rows_.begin()) + (transposed ? 1 : 0);
}

void BlockMatrix::add_block(int i, int j, const Eigen::Matrix3d& b) {
  const int code = block_code(i, j);
  assert(code >= 0 && "block outside the Hessian pattern");
  add(code, b);
}

void BlockMatrix::add_outer(const std::vector<int>& verts, const Eigen::VectorXd& u, double coef) {
  const int k = static_cast<int>(verts.size());
  for (int a = 0; a < k; ++a)
    for (int b = 0; b < k; ++b)
      if (storage_ == BlockStorage::full || verts[a] >= verts[b])
        add_block(verts[a], verts[b], coef * u.segment<3>(3 * a) * u.segment<3>(3 * b).transpose());
}

void BlockMatrix::set_zero() {
  std::fill(m_.valuePtr(), m_.valuePtr() + m_.nonZeros(), 0.0);
}

double BlockMatrix::trace() const {
  double t = 0.0;
  for (const int k : diagonal_) {
    const double* d = m_.valuePtr() + start_[k];
    t += d[0] + d[stride_[k] + 1] + d[2 * stride_[k] + 2];
  }
  return t;
}

void BlockMatrix::shift_diagonal(double s) {
  for (const int k : diagonal_) {
    double* d = m_.valuePtr() + start_[k];
    for (int r = 0; r < 3; ++r) d[r * stride_[k] + r] += s;
  }
}

}  // namespace rbc
