#pragma once
// A symmetric sparse matrix of 3 x 3 vertex blocks with a fixed pattern: the Newton
// Hessian of energies whose terms each live in one closed vertex star (membrane elements,
// hinges, Juelicher vertex cells, area and volume). The pattern is built once per mesh;
// assembly adds into the values in place, so no triplet list is rebuilt per iteration.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "core/block_pattern.hpp"
#include "core/mesh.hpp"

namespace rbc {

class BlockHessian {
 public:
  /// Pattern: every vertex pair (i, j) that shares a closed vertex star (i, j within two
  /// edges of each other), both triangles stored. Size 3N x 3N.
  explicit BlockHessian(const Topology& topo);

  void set_zero();
  /// Adds the 3 x 3 block b at (i, j). (i, j) must be in the pattern (debug-asserted).
  void add_block(int i, int j, const Eigen::Matrix3d& b);
  /// Adds a local K x K block matrix h (3K x 3K) over the vertices verts[0..K).
  template <int K>
  void add_local(const int (&verts)[K], const Eigen::Matrix<double, 3 * K, 3 * K>& h) {
    for (int a = 0; a < K; ++a)
      for (int b = 0; b < K; ++b)
        add_block(verts[a], verts[b], h.template block<3, 3>(3 * a, 3 * b));
  }
  /// Adds coef * u u^T with u stacked 3-vectors over verts (u has 3 verts.size() entries).
  void add_outer(const std::vector<int>& verts, const Eigen::VectorXd& u, double coef);

  const Eigen::SparseMatrix<double>& matrix() const { return m_; }
  Eigen::SparseMatrix<double>& matrix() { return m_; }

 private:
  int position(int i, int j) const;  ///< index of i in the sorted block column of j
  std::vector<int> offsets_, rows_;  ///< block-column lists: rows_[offsets_[j]..offsets_[j+1])
  Eigen::SparseMatrix<double> m_;
};

}  // namespace rbc
