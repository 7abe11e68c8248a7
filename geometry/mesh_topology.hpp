// Whole-mesh topology: connected components, orientation consistency, boundary and non-manifold
// edges, Euler characteristic. cmm-plan prints it so an operator sees a broken mesh before planning.
#pragma once

#include <cstddef>
#include <vector>

#include "geometry/edge_adjacency.hpp"

namespace cmm::geometry {

struct TopologyReport {
  int components = 0;
  std::size_t boundary_edges = 0;      // used by one face
  std::size_t non_manifold_edges = 0;  // used by more than two faces
  // Two-face edges whose faces run the edge the same way: the normals of one side are flipped.
  std::size_t inconsistently_oriented_edges = 0;
  long euler_characteristic = 0;  // V − E + F over referenced vertices
  bool closed() const { return boundary_edges == 0 && non_manifold_edges == 0; }
};

// Component index per face; faces are connected through shared edges.
std::vector<int> face_components(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, int* component_count);

TopologyReport topology_report(const TriangleMesh& mesh, const EdgeAdjacency& adjacency);

}  // namespace cmm::geometry
