// A hole whose wall the scan saw only in part: the seen region's border runs round the wall, at a depth
// that varies with how far each view looked in, so no plane holds it and it is no rim. The facets
// beside such a loop face one axis; the wall grown from them over facets facing that axis gives the
// cylinder (its axis from the facets' normals, its centre and radius from its vertices across the axis)
// and the entry rim, where the wall ends toward the face it opens in.
#pragma once

#include <optional>

#include "geometry/boundary_loops.hpp"
#include "geometry/circle_fit.hpp"
#include "geometry/edge_adjacency.hpp"
#include "geometry/face_geometry.hpp"

namespace cmm::geometry {

struct WallHole {
  Vec3 entry_centre = Vec3::Zero();  // on the axis, where the seen wall ends toward the opening face
  Vec3 axis = Vec3::UnitZ();         // unit, out of the material at the entry
  double radius = 0;
  double roundness_mm = 0;           // peak to valley of the wall's vertices about the fitted circle
  double rms_mm = 0;
  double seen_depth_mm = 0;          // the wall's length along the axis, entry to the deepest seen point
  std::vector<int> wall_faces;
};

// The circle a bore's wall runs round, across `axis`: fitted to the vertices of the wall facets within
// 15° of the axis (where the wall rounds into a face, a noisy mesh's vertices lie inside the circle),
// then again without those beyond 3 RMS. Its normal is `axis`. Empty with fewer than 8 such vertices.
std::optional<Circle3> wall_circle(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& wall, const Vec3& axis);

// The wall's facets whose centroids lie more than `margin` from both its ends along `axis`: away from
// its rims, where a noisy mesh rounds the crease (and leans the facets) and a seen wall's border is ragged.
std::vector<int> wall_middle(const TriangleMesh& mesh, const std::vector<int>& wall, const Vec3& axis, double margin);

// How far from its ends a noisy mesh's wall is rounded into its rims: about two bins at ε ≤ 0.2 mm.
constexpr double kRimZoneMm = 1.0;

// `loop` is a hole loop of `mesh`; `circle_tolerance` the share of the radius the wall's vertices may
// scatter about the circle (RMS). Empty when the loop does not run once round an axis or the facets
// beside it are not a wall facing that axis.
std::optional<WallHole> wall_hole(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                                  const BoundaryLoop& loop, double circle_tolerance);

}  // namespace cmm::geometry
