// Ordered boundary loops of an open mesh, each classified as the outer boundary of its patch or a
// hole in it: a scan that lost a bore wall leaves a hole loop where the bore was.
#pragma once

#include <vector>

#include "geometry/edge_adjacency.hpp"

namespace cmm::geometry {

enum class LoopKind { outer, hole };

struct BoundaryLoop {
  std::vector<int> vertices;    // in the faces' winding order: the surface lies to the left
  std::vector<int> half_edges;  // half_edges[i] runs from vertices[i] to the next vertex
  int component = 0;
  LoopKind kind = LoopKind::outer;
  double perimeter = 0;
  // Unit normal of the surface next to the loop, averaged (area-weighted) over the boundary faces.
  Vec3 surface_normal = Vec3::UnitZ();
};

std::vector<BoundaryLoop> boundary_loops(const TriangleMesh& mesh, const EdgeAdjacency& adjacency);

}  // namespace cmm::geometry
