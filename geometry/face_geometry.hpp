// Per-face unit normals, areas and centroids, computed once and shared by the feature code.
// A zero-area face gets a zero normal so that it weighs nothing anywhere it is averaged.
#pragma once

#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct FaceGeometry {
  Points normals;    // F × 3, unit (or zero for a degenerate face)
  Points centroids;  // F × 3
  std::vector<double> areas;
};

FaceGeometry face_geometry(const TriangleMesh& mesh);

}  // namespace cmm::geometry
