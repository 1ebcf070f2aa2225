// SPDX-License-Identifier: GPL-3.0-or-later
#include "core/mesh.hpp"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

namespace rbc {
namespace {

Adjacency make_adjacency(int n, const std::vector<std::pair<int, int>>& pairs) {
  Adjacency adj;
  adj.offsets.assign(n + 1, 0);
  for (const auto& [owner, item] : pairs) ++adj.offsets[owner + 1];
  for (int i = 0; i < n; ++i) adj.offsets[i + 1] += adj.offsets[i];
  adj.items.resize(pairs.size());
  std::vector<int> fill(adj.offsets.begin(), adj.offsets.end() - 1);
  for (const auto& [owner, item] : pairs) adj.items[fill[owner]++] = item;
  return adj;
}

}  // namespace

Topology build_topology(const Faces& faces, int num_vertices) {
  Topology t;
  t.num_vertices = num_vertices;
  t.faces = faces;
  const int nf = static_cast<int>(faces.cols());
  // Directed half-edge (a,b) -> face; each undirected edge must appear once each way.
  std::map<std::pair<int, int>, std::pair<int, int>> half;  // (a,b) -> (face, opposite)
  for (int f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      const int a = faces(k, f), b = faces((k + 1) % 3, f), c = faces((k + 2) % 3, f);
      if (a < 0 || a >= num_vertices || b < 0 || b >= num_vertices)
        throw std::invalid_argument("face " + std::to_string(f) +
                                    " has a vertex index outside [0, " +
                                    std::to_string(num_vertices) + ")");
      if (a == b) throw std::invalid_argument("face " + std::to_string(f) + " is degenerate");
      if (!half.emplace(std::make_pair(a, b), std::make_pair(f, c)).second)
        throw std::invalid_argument("mesh is not an oriented manifold: half-edge (" +
                                    std::to_string(a) + "," + std::to_string(b) +
                                    ") appears twice");
    }
  }
  std::vector<std::array<int, 6>> edges;  // a, b, f0, f1, opp0, opp1
  for (const auto& [ab, fo] : half) {
    const auto [a, b] = ab;
    if (a > b) continue;
    auto twin = half.find({b, a});
    if (twin == half.end())
      throw std::invalid_argument("mesh is not closed: edge (" + std::to_string(a) + "," +
                                  std::to_string(b) + ") has only one face");
    edges.push_back({a, b, fo.first, twin->second.first, fo.second, twin->second.second});
  }
  const int ne = static_cast<int>(edges.size());
  t.edges.resize(2, ne);
  t.edge_faces.resize(2, ne);
  t.edge_opposite.resize(2, ne);
  std::vector<std::pair<int, int>> ve, vn, vf;
  for (int e = 0; e < ne; ++e) {
    const auto& r = edges[e];
    t.edges.col(e) << r[0], r[1];
    t.edge_faces.col(e) << r[2], r[3];
    t.edge_opposite.col(e) << r[4], r[5];
    ve.emplace_back(r[0], e);
    ve.emplace_back(r[1], e);
    vn.emplace_back(r[0], r[1]);
    vn.emplace_back(r[1], r[0]);
  }
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) vf.emplace_back(faces(k, f), f);
  t.vertex_edges = make_adjacency(num_vertices, ve);
  t.vertex_neighbours = make_adjacency(num_vertices, vn);
  t.vertex_faces = make_adjacency(num_vertices, vf);
  for (int v = 0; v < num_vertices; ++v)
    if (t.vertex_faces.size(v) == 0)
      throw std::invalid_argument("vertex " + std::to_string(v) + " belongs to no face");
  return t;
}

std::vector<int> degree_histogram(const Topology& topo) {
  std::vector<int> hist;
  for (int v = 0; v < topo.num_vertices; ++v) {
    const int d = topo.vertex_neighbours.size(v);
    if (static_cast<int>(hist.size()) <= d) hist.resize(d + 1, 0);
    ++hist[d];
  }
  return hist;
}

}  // namespace rbc
