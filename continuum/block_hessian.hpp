// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The continuum Newton Hessian's pattern: core/block_pattern.hpp's BlockMatrix (the one
// block assembler) over every vertex pair that shares a closed vertex star, the reach of
// the energies whose terms each live in one star (membrane elements, hinges, Juelicher
// vertex cells, area and volume). The block codes of every face (3 x 3 vertex pairs), hinge
// (4 x 4) and vertex star (s x s) are looked up once per mesh, so assembly adds through them
// without a search (add_face, add_hinge, add_star_outer).
#include <vector>

#include "core/block_pattern.hpp"
#include "core/mesh.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/element_hessian.hpp"

namespace rbc {

class BlockHessian : public BlockMatrix {
 public:
  /// Pattern: every vertex pair (i, j) within two edges of each other; both triangles
  /// stored (full) or the blocks on and below the diagonal only (lower: what the sparse
  /// Cholesky reads). Size 3N x 3N.
  explicit BlockHessian(const Topology& topo, BlockStorage storage = BlockStorage::full);

  /// Adds the symmetric 9 x 9 matrix h of face f (vertex order of topo.faces).
  void add_face(int f, const Matrix9d& h) { add_codes<3>(&face_codes_[9 * f], h); }
  /// Adds the symmetric 12 x 12 matrix h of hinge e (a, b, opposite0, opposite1).
  void add_hinge(int e, const Matrix12d& h) { add_codes<4>(&hinge_codes_[16 * e], h); }
  /// Adds coef u u^T, u: 3 entries per vertex of the closed star of v (stars() order).
  void add_star_outer(int v, const double* u, double coef);
  /// The closed vertex stars (v first), as discrete/bending_energy.hpp's Juelicher terms use.
  const VertexStars& stars() const { return stars_; }

  /// Element matrices of one assembly, laid out for add_elements_share: face f's 9 x 9,
  /// hinge e's 12 x 12, and vertex v's star vector u_v (3 stars().size(v) entries from
  /// star_vector_offset(v)) with its coefficient. Kept between assemblies so that a Newton
  /// solve allocates them once (they hold no state: every assembly overwrites them).
  struct ElementBuffers {
    std::vector<Matrix9d> faces;
    std::vector<Matrix12d> hinges;
    std::vector<double> star_vectors, star_coefs;
  };
  /// The buffers sized for this mesh (contents unspecified).
  ElementBuffers& element_buffers();
  /// Offset of vertex v's star vector in ElementBuffers::star_vectors.
  int star_vector_offset(int v) const { return 3 * (stars_.offsets[v]); }
  /// Adds every face matrix, then every hinge matrix, then every star's coef u u^T of b, each
  /// in index order, into the stored blocks of share `part` of `parts` (a contiguous range of
  /// block indices). Calling it for parts 0 .. parts-1 (one per thread, concurrently) adds
  /// each block's terms in the serial order, so the matrix is bit-identical to parts = 1 and
  /// does not depend on the thread count.
  void add_elements_share(const ElementBuffers& b, int part, int parts);

 private:
  template <int K>
  void add_codes(const int* codes, const Eigen::Matrix<double, 3 * K, 3 * K>& h) {
    for (int a = 0; a < K; ++a)
      for (int b = 0; b < K; ++b)
        if (codes[K * a + b] >= 0) add(codes[K * a + b], h.template block<3, 3>(3 * a, 3 * b));
  }
  /// Code of the pair (i, j) of a local matrix, -1 where lower storage keeps only (j, i).
  int local_code(int i, int j) const;
  std::vector<int> face_codes_, hinge_codes_;
  VertexStars stars_;
  std::vector<int> star_code_offsets_, star_codes_;
  ElementBuffers buffers_;
};

}  // namespace rbc
