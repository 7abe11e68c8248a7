// Edge adjacency by bucketing half-edges on their lower vertex: O(F) and no global sort, because
// the 4M-triangle benchmark must extract features in at most twice the time it takes to read them.
#include "geometry/edge_adjacency.hpp"

#include <algorithm>

namespace cmm::geometry {

int EdgeAdjacency::other_face(int e, int face) const {
  if (use_count(e) != 2) return -1;
  const int a = face_of(half_edge(e, 0));
  const int b = face_of(half_edge(e, 1));
  return a == face ? b : a;
}

EdgeAdjacency edge_adjacency(const TriangleMesh& mesh) {
  const int face_count = static_cast<int>(mesh.faces.rows());
  const int vertex_count = static_cast<int>(mesh.vertices.rows());
  const int half_count = 3 * face_count;
  auto endpoints = [&](int h) {
    const int f = h / 3, k = h % 3;
    const int a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
    return std::pair{std::min(a, b), std::max(a, b)};
  };

  // Counting sort of half-edges by their lower vertex.
  std::vector<int> bucket_start(vertex_count + 1, 0);
  for (int h = 0; h < half_count; ++h) ++bucket_start[endpoints(h).first + 1];
  for (int v = 0; v < vertex_count; ++v) bucket_start[v + 1] += bucket_start[v];
  std::vector<int> by_low(half_count);
  {
    std::vector<int> fill(bucket_start.begin(), bucket_start.end() - 1);
    for (int h = 0; h < half_count; ++h) by_low[fill[endpoints(h).first]++] = h;
  }

  // Within a bucket (a vertex's few edges) group by the upper vertex.
  EdgeAdjacency adj;
  adj.face_edges.resize(face_count, 3);
  std::vector<int> edge_of_half(half_count);
  std::vector<std::pair<int, int>> edge_list;
  edge_list.reserve(half_count / 2 + 16);
  for (int v = 0; v < vertex_count; ++v) {
    const int begin = bucket_start[v], end = bucket_start[v + 1];
    const int first_edge = static_cast<int>(edge_list.size());
    for (int i = begin; i < end; ++i) {
      const int h = by_low[i];
      const int hi = endpoints(h).second;
      int e = -1;
      for (int c = first_edge; c < static_cast<int>(edge_list.size()); ++c)
        if (edge_list[c].second == hi) { e = c; break; }
      if (e < 0) {
        e = static_cast<int>(edge_list.size());
        edge_list.emplace_back(v, hi);
      }
      edge_of_half[h] = e;
    }
  }

  const int edge_count = static_cast<int>(edge_list.size());
  adj.edges.resize(edge_count, 2);
  for (int e = 0; e < edge_count; ++e) adj.edges.row(e) << edge_list[e].first, edge_list[e].second;
  adj.half_edge_start.assign(edge_count + 1, 0);
  for (int h = 0; h < half_count; ++h) {
    adj.face_edges(h / 3, h % 3) = edge_of_half[h];
    ++adj.half_edge_start[edge_of_half[h] + 1];
  }
  for (int e = 0; e < edge_count; ++e) adj.half_edge_start[e + 1] += adj.half_edge_start[e];
  adj.half_edges.resize(half_count);
  std::vector<int> fill(adj.half_edge_start.begin(), adj.half_edge_start.end() - 1);
  for (int h = 0; h < half_count; ++h) adj.half_edges[fill[edge_of_half[h]]++] = h;
  return adj;
}

}  // namespace cmm::geometry
