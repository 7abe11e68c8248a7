// Edge adjacency by bucketing half-edges on their lower vertex: linear time, and after the one
// scattering pass everything runs sequentially, because the 4M-triangle benchmark must extract
// features in at most twice the time it takes to read them.
#include "geometry/edge_adjacency.hpp"

#include <algorithm>
#include <utility>

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
  // Endpoints are recomputed rather than stored: fresh memory is the dominant cost on big meshes.
  auto low = [&](int h) {
    const int f = h / 3, k = h % 3;
    return std::min(mesh.faces(f, k), mesh.faces(f, k == 2 ? 0 : k + 1));
  };
  auto high = [&](int h) {
    const int f = h / 3, k = h % 3;
    return std::max(mesh.faces(f, k), mesh.faces(f, k == 2 ? 0 : k + 1));
  };

  // Counting sort of half-edges by their lower vertex (stable: ascending half-edge within a bucket).
  std::vector<int> bucket_start(vertex_count + 1, 0);
  for (int h = 0; h < half_count; ++h) ++bucket_start[low(h) + 1];
  for (int v = 0; v < vertex_count; ++v) bucket_start[v + 1] += bucket_start[v];
  std::vector<int> by_low(half_count);
  {
    std::vector<int> fill(bucket_start.begin(), bucket_start.end() - 1);
    for (int h = 0; h < half_count; ++h) by_low[fill[low(h)]++] = h;
  }

  // Within a bucket (a vertex's few edges), order by the upper vertex; each run is one edge.
  // Insertion sort: a bucket holds a handful, and std::stable_sort would allocate for each.
  int edge_count = 0;
  for (int v = 0; v < vertex_count; ++v) {
    const auto begin = by_low.begin() + bucket_start[v], end = by_low.begin() + bucket_start[v + 1];
    for (auto it = begin + (begin != end); it < end; ++it) {
      const int h = *it, key = high(h);
      auto hole = it;
      for (; hole != begin && high(*(hole - 1)) > key; --hole) *hole = *(hole - 1);
      *hole = h;
    }
    for (auto it = begin; it != end; ++it) edge_count += it == begin || high(*it) != high(*(it - 1));
  }

  EdgeAdjacency adj;
  adj.face_edges.resize(face_count, 3);
  adj.edges.resize(edge_count, 2);
  adj.half_edge_start.resize(edge_count + 1);
  int e = -1;
  for (int v = 0; v < vertex_count; ++v) {
    for (int i = bucket_start[v]; i < bucket_start[v + 1]; ++i) {
      const int h = by_low[i];
      if (i == bucket_start[v] || high(h) != high(by_low[i - 1])) {
        ++e;
        adj.edges.row(e) << v, high(h);
        adj.half_edge_start[e] = i;
      }
      adj.face_edges(h / 3, h % 3) = e;
    }
  }
  adj.half_edge_start[edge_count] = half_count;
  adj.half_edges = std::move(by_low);
  return adj;
}

}  // namespace cmm::geometry
