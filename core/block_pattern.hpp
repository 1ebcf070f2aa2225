#pragma once
// Fixed sparsity pattern of a 3N x 3N matrix made of 3 x 3 vertex blocks (Newton Hessians of
// vertex-based energies). Built once per mesh from the block columns; the scalar CSC matrix
// holds explicit zeros so assembly adds into valuePtr() in place, with no triplet list per
// iteration. Shared by the continuum Hessian (full pattern) and the discrete network Hessian
// (lower triangle).
#include <Eigen/SparseCore>
#include <vector>

namespace rbc {

struct BlockPattern {
  /// Block column j lists its block rows, sorted: rows[col_offsets[j] .. col_offsets[j+1]).
  std::vector<int> col_offsets, rows;
  /// Scalar CSC matrix, all stored values zero: column 3j + c holds rows 3i + r (r = 0, 1, 2)
  /// of every block row i of block column j, in order, so block k of column j starts at
  /// outerIndexPtr()[3j + c] + 3 (k - col_offsets[j]).
  Eigen::SparseMatrix<double> matrix;
};

/// Builds the pattern from unsorted block-row lists per block column (duplicates allowed).
BlockPattern make_block_pattern(std::vector<std::vector<int>> block_columns);

}  // namespace rbc
