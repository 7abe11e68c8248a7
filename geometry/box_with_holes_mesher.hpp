// Meshes an axis-aligned box with vertical cylindrical through holes (the cube, the case 3 block, the
// plate): grid faces with rings around each hole, and every sharp-edge vertex exactly on its true edge.
#pragma once

#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

// A hole along z through the whole box, by the position of its axis.
struct VerticalHole {
  double x = 0;
  double y = 0;
  double radius = 0;
};

// The box [0, size.x] × [0, size.y] × [0, size.z] minus the holes, outward-oriented and watertight,
// with edges of about edge_length. Each hole sits in an octagon of grid cells reaching
// max(2 edge_length, 0.3 radius) beyond its rim; throws std::invalid_argument when octagons would
// overlap or the rim would come within edge_length / 2 of a box side, i.e. when edge_length is too
// coarse for the hole layout.
TriangleMesh mesh_box_with_holes(const Vec3& size, const std::vector<VerticalHole>& holes, double edge_length);

}  // namespace cmm::geometry
