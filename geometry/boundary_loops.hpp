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

// Where a loop lies: the centroid of its sides weighted by their length, which does not move with how
// densely its vertices are spaced (a scan's border is denser where the views overlapped).
Vec3 loop_centre(const TriangleMesh& mesh, const std::vector<int>& vertices);

}  // namespace cmm::geometry
