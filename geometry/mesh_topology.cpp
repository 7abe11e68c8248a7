// Components by union–find over shared edges; the rest is counting on the adjacency.
#include "geometry/mesh_topology.hpp"

#include <numeric>

namespace cmm::geometry {
namespace {

int find_root(std::vector<int>& parent, int x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// Union–find over faces joined by shared edges; roots are the smallest face of each component.
std::vector<int> face_roots(const TriangleMesh& mesh, const EdgeAdjacency& adjacency) {
  std::vector<int> parent(mesh.faces.rows());
  std::iota(parent.begin(), parent.end(), 0);
  for (int e = 0; e < adjacency.edge_count(); ++e) {
    const int first = EdgeAdjacency::face_of(adjacency.half_edge(e, 0));
    for (int i = 1; i < adjacency.use_count(e); ++i) {
      const int a = find_root(parent, first);
      const int b = find_root(parent, EdgeAdjacency::face_of(adjacency.half_edge(e, i)));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  return parent;
}

}  // namespace

std::vector<int> face_components(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, int* component_count) {
  const int face_count = static_cast<int>(mesh.faces.rows());
  std::vector<int> parent = face_roots(mesh, adjacency);
  std::vector<int> component(face_count, -1), label(face_count, -1);
  int count = 0;
  for (int f = 0; f < face_count; ++f) {
    const int root = find_root(parent, f);
    if (label[root] < 0) label[root] = count++;
    component[f] = label[root];
  }
  if (component_count) *component_count = count;
  return component;
}

TopologyReport topology_report(const TriangleMesh& mesh, const EdgeAdjacency& adjacency) {
  TopologyReport report;
  std::vector<int> parent = face_roots(mesh, adjacency);
  for (int f = 0; f < static_cast<int>(parent.size()); ++f) report.components += find_root(parent, f) == f;
  for (int e = 0; e < adjacency.edge_count(); ++e) {
    const int uses = adjacency.use_count(e);
    if (uses == 1) ++report.boundary_edges;
    if (uses > 2) ++report.non_manifold_edges;
    if (uses == 2) {
      // Consistent neighbours traverse the shared edge in opposite directions.
      const int h0 = adjacency.half_edge(e, 0), h1 = adjacency.half_edge(e, 1);
      const int start0 = mesh.faces(EdgeAdjacency::face_of(h0), EdgeAdjacency::side_of(h0));
      const int start1 = mesh.faces(EdgeAdjacency::face_of(h1), EdgeAdjacency::side_of(h1));
      if (start0 == start1) ++report.inconsistently_oriented_edges;
    }
  }
  std::vector<char> used(mesh.vertices.rows(), 0);
  for (int f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[mesh.faces(f, k)] = 1;
  const long vertex_count = std::accumulate(used.begin(), used.end(), 0L);
  report.euler_characteristic = vertex_count - adjacency.edge_count() + static_cast<long>(mesh.faces.rows());
  return report;
}

}  // namespace cmm::geometry
