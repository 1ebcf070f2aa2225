// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Closed, oriented triangle meshes: positions and the connectivity the energies need.
#include <Eigen/Core>
#include <array>
#include <vector>

namespace rbc {

/// Vertex positions, 3 x N (column i is vertex i), in um. Column-major, so the
/// flat view (see flat()) is (x0, y0, z0, x1, ...), the layout minimisers use.
using Positions = Eigen::Matrix3Xd;
/// Triangles, 3 x F vertex indices, counter-clockwise seen from outside.
using Faces = Eigen::Matrix3Xi;

inline Eigen::Map<Eigen::VectorXd> flat(Positions& x) {
  return {x.data(), x.size()};
}
inline Eigen::Map<const Eigen::VectorXd> flat(const Positions& x) {
  return {x.data(), x.size()};
}

/// Compressed adjacency lists: the neighbours of item i are
/// items[offsets[i] .. offsets[i+1]).
struct Adjacency {
  std::vector<int> offsets;
  std::vector<int> items;
  int size(int i) const { return offsets[i + 1] - offsets[i]; }
  const int* begin(int i) const { return items.data() + offsets[i]; }
  const int* end(int i) const { return items.data() + offsets[i + 1]; }
};

/// Connectivity of a closed oriented 2-manifold triangle mesh (genus 0 for the cell,
/// a torus for periodic patches). Built once by build_topology(); immutable after.
struct Topology {
  int num_vertices = 0;
  Faces faces;             ///< 3 x F
  Eigen::Matrix2Xi edges;  ///< 2 x E, edges(0,e) < edges(1,e)
  /// 2 x E: the two faces sharing edge e. Face edge_faces(0,e) traverses the edge
  /// as edges(0,e) -> edges(1,e); face edge_faces(1,e) traverses it backwards.
  Eigen::Matrix2Xi edge_faces;
  /// 2 x E: the vertex opposite edge e in edge_faces(0,e) and edge_faces(1,e).
  Eigen::Matrix2Xi edge_opposite;
  Adjacency vertex_faces;       ///< faces around each vertex
  Adjacency vertex_edges;       ///< edges incident to each vertex
  Adjacency vertex_neighbours;  ///< 1-ring vertices

  int num_faces() const { return static_cast<int>(faces.cols()); }
  int num_edges() const { return static_cast<int>(edges.cols()); }
};

/// Builds the connectivity and checks that the mesh is a closed, consistently
/// oriented manifold (every edge in exactly two faces, traversed once each way).
/// Throws std::invalid_argument naming the first offending edge otherwise.
Topology build_topology(const Faces& faces, int num_vertices);

/// A triangle mesh: positions plus connectivity.
struct TriMesh {
  Positions x;  ///< 3 x N, um
  Topology topo;
};

/// Vertex-degree histogram: result[d] = number of vertices with d neighbours.
std::vector<int> degree_histogram(const Topology& topo);

}  // namespace rbc
