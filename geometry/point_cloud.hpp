// Point cloud value type: a raw scan before thinning and triangulation (thesis Ch. 3–4).
// Normals are optional: a scanner may or may not deliver them.
#pragma once

#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct PointCloud {
  Points points;   // N × 3
  Points normals;  // N × 3 when known, else 0 × 3
};

}  // namespace cmm::geometry
