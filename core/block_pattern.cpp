#include "core/block_pattern.hpp"

#include <algorithm>

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

}  // namespace rbc
