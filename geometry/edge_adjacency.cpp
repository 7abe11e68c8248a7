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
  std::vector<int> low(half_count), high(half_count);
  for (int f = 0; f < face_count; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.faces(f, k), b = mesh.faces(f, k == 2 ? 0 : k + 1);
      low[3 * f + k] = std::min(a, b);
      high[3 * f + k] = std::max(a, b);
    }

  // Counting sort of half-edges by their lower vertex (stable: ascending half-edge within a bucket).
  std::vector<int> bucket_start(vertex_count + 1, 0);
  for (int h = 0; h < half_count; ++h) ++bucket_start[low[h] + 1];
  for (int v = 0; v < vertex_count; ++v) bucket_start[v + 1] += bucket_start[v];
  std::vector<int> by_low(half_count);
  {
    std::vector<int> fill(bucket_start.begin(), bucket_start.end() - 1);
    for (int h = 0; h < half_count; ++h) by_low[fill[low[h]]++] = h;
  }

  // Within a bucket (a vertex's few edges), order by the upper vertex; each run is one edge.
  EdgeAdjacency adj;
  adj.face_edges.resize(face_count, 3);
  adj.edges.resize(half_count, 2);  // an upper bound, trimmed below
  adj.half_edge_start.reserve(half_count + 1);
  adj.half_edges.resize(half_count);
  int edge_count = 0;
  for (int v = 0; v < vertex_count; ++v) {
    const auto begin = by_low.begin() + bucket_start[v], end = by_low.begin() + bucket_start[v + 1];
    // Insertion sort: a bucket holds a handful, and std::stable_sort would allocate for each.
    for (auto it = begin + (begin != end); it < end; ++it) {
      const int h = *it;
      auto hole = it;
      for (; hole != begin && high[*(hole - 1)] > high[h]; --hole) *hole = *(hole - 1);
      *hole = h;
    }
    for (auto run = begin; run != end;) {
      auto run_end = run;
      while (run_end != end && high[*run_end] == high[*run]) ++run_end;
      adj.edges.row(edge_count) << v, high[*run];
      adj.half_edge_start.push_back(static_cast<int>(run - by_low.begin()));
      for (auto it = run; it != run_end; ++it) adj.face_edges(*it / 3, *it % 3) = edge_count;
      ++edge_count;
      run = run_end;
    }
  }
  adj.half_edge_start.push_back(half_count);
  adj.half_edges = std::move(by_low);
  adj.edges.conservativeResize(edge_count, 2);
  return adj;
}

}  // namespace cmm::geometry
