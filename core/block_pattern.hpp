// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The one block-sparse assembler of the project: a symmetric 3N x 3N matrix of 3 x 3 vertex
// blocks (Newton Hessians of vertex-based energies) with a fixed pattern built once per mesh.
// The scalar CSC matrix holds explicit zeros so assembly adds into valuePtr() in place, with
// no triplet list per iteration. Used by the continuum Newton Hessian (full storage,
// continuum/block_hessian.hpp) and the discrete network preconditioner (lower triangle,
// discrete/network_hessian.hpp).
#include <Eigen/Core>
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

/// Which triangles of the symmetric matrix are stored.
enum class BlockStorage {
  full,   ///< both triangles (Eigen's general sparse solvers)
  lower,  ///< block rows >= block column only (CHOLMOD / SimplicialLDLT with Eigen::Lower)
};

/// A symmetric block matrix over a fixed pattern. A block (i, j) is addressed by a code
/// (block_code): look it up once per mesh and add through it every assembly, or add by
/// vertex pair (add_block) where the lookup cost does not matter.
class BlockMatrix {
 public:
  /// block_columns[j]: block rows of block column j (unsorted, duplicates allowed); with
  /// BlockStorage::lower only rows >= j may be listed, and the diagonal must be.
  BlockMatrix(std::vector<std::vector<int>> block_columns, BlockStorage storage);

  BlockStorage storage() const { return storage_; }
  int num_blocks() const { return static_cast<int>(rows_.size()); }

  /// 2 x (stored block index) + 1 if (i, j) is stored as the transpose of block (j, i)
  /// (lower storage, i < j); -1 if (i, j) is outside the pattern.
  int block_code(int i, int j) const;
  /// Adds the 3 x 3 block b of the symmetric matrix at (i, j) through its code (>= 0).
  void add(int code, const Eigen::Matrix3d& b) {
    const int blk = code >> 1;
    double* v = m_.valuePtr() + start_[blk];
    const int s = stride_[blk];
    if (code & 1) {
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) v[c * s + r] += b(c, r);
    } else {
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) v[c * s + r] += b(r, c);
    }
  }
  /// Adds b at (i, j); (i, j) must be in the pattern (debug-asserted). With lower storage a
  /// block above the diagonal is stored transposed, so add each symmetric pair once.
  void add_block(int i, int j, const Eigen::Matrix3d& b);
  /// Adds b to the diagonal block of vertex v.
  void add_diagonal(int v, const Eigen::Matrix3d& b) { add(2 * diagonal_[v], b); }
  /// Adds a symmetric local matrix h (3K x 3K, vertex-major over verts[0..K)): every block
  /// with full storage, the blocks on and below the diagonal with lower storage.
  template <int K>
  void add_local(const int (&verts)[K], const Eigen::Matrix<double, 3 * K, 3 * K>& h) {
    for (int a = 0; a < K; ++a)
      for (int b = 0; b < K; ++b)
        if (storage_ == BlockStorage::full || verts[a] >= verts[b])
          add_block(verts[a], verts[b], h.template block<3, 3>(3 * a, 3 * b));
  }
  /// Adds coef u u^T with u stacked 3-vectors over verts (u has 3 verts.size() entries).
  void add_outer(const std::vector<int>& verts, const Eigen::VectorXd& u, double coef);

  void set_zero();
  /// Sum of the diagonal entries (trace).
  double trace() const;
  /// Adds s to every diagonal entry.
  void shift_diagonal(double s);

  const Eigen::SparseMatrix<double>& matrix() const { return m_; }
  Eigen::SparseMatrix<double>& matrix() { return m_; }

 private:
  BlockStorage storage_;
  std::vector<int> col_offsets_, rows_;  ///< block-column lists, sorted rows
  std::vector<int> start_, stride_;      ///< scalar value index of each block, column stride
  std::vector<int> diagonal_;            ///< block index of (v, v)
  Eigen::SparseMatrix<double> m_;
};

}  // namespace rbc
