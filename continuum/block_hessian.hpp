#pragma once
// The continuum Newton Hessian's pattern: core/block_pattern.hpp's BlockMatrix (the one
// block assembler) over every vertex pair that shares a closed vertex star, the reach of
// the energies whose terms each live in one star (membrane elements, hinges, Juelicher
// vertex cells, area and volume).
#include "core/block_pattern.hpp"
#include "core/mesh.hpp"

namespace rbc {

class BlockHessian : public BlockMatrix {
 public:
  /// Pattern: every vertex pair (i, j) within two edges of each other, both triangles
  /// stored. Size 3N x 3N.
  explicit BlockHessian(const Topology& topo);
};

}  // namespace rbc
