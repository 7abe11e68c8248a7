// Per-face unit normals and areas, computed once and shared by the feature code; centroids on demand
// (only the few faces near reference points need them, and 24 MB of fresh memory per 1M faces is not free).
// A zero-area face gets a zero normal so that it weighs nothing anywhere it is averaged.
#pragma once

#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct FaceGeometry {
  Points normals;  // F × 3, unit (or zero for a degenerate face)
  std::vector<double> areas;
};

FaceGeometry face_geometry(const TriangleMesh& mesh);

inline Vec3 face_centroid(const TriangleMesh& mesh, int f) {
  return (vertex(mesh, mesh.faces(f, 0)) + vertex(mesh, mesh.faces(f, 1)) + vertex(mesh, mesh.faces(f, 2))) / 3.0;
}

}  // namespace cmm::geometry
