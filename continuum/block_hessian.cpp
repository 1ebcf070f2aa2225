#include "continuum/block_hessian.hpp"

#include <vector>

namespace rbc {
namespace {

std::vector<std::vector<int>> closed_star_columns(const Topology& topo) {
  const int n = topo.num_vertices;
  std::vector<std::vector<int>> cols(n);
  std::vector<int> star;
  for (int v = 0; v < n; ++v) {
    star.assign(1, v);
    star.insert(star.end(), topo.vertex_neighbours.begin(v), topo.vertex_neighbours.end(v));
    for (int a : star)
      for (int b : star) cols[b].push_back(a);
  }
  return cols;
}

}  // namespace

BlockHessian::BlockHessian(const Topology& topo)
    : BlockMatrix(closed_star_columns(topo), BlockStorage::full) {}

}  // namespace rbc
