// Edge–face adjacency of a triangle mesh: its undirected edges, which face sides use each, and which
// edge each face side is. Built once in linear time; all topology and feature code reads it.
#pragma once

#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

using Edges = Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>;

// Side k of face f runs from faces(f, k) to faces(f, (k + 1) % 3) and is "half-edge" 3·f + k.
struct EdgeAdjacency {
  Edges edges;                          // E × 2, first index < second
  Triangles face_edges;                 // F × 3: edge of side k of face f
  std::vector<int> half_edge_start;     // E + 1 offsets into half_edges (CSR)
  std::vector<int> half_edges;          // the half-edges on each edge, ascending

  int edge_count() const { return static_cast<int>(edges.rows()); }
  int use_count(int e) const { return half_edge_start[e + 1] - half_edge_start[e]; }
  int half_edge(int e, int i) const { return half_edges[half_edge_start[e] + i]; }
  static int face_of(int half_edge) { return half_edge / 3; }
  static int side_of(int half_edge) { return half_edge % 3; }
  // The other face on a two-face (manifold) edge, or -1.
  int other_face(int e, int face) const;
};

EdgeAdjacency edge_adjacency(const TriangleMesh& mesh);

}  // namespace cmm::geometry
