// Meshes an axis-aligned box with vertical through holes, round or slots (the cube, the case 3 block,
// the plates): grid faces with rings around each hole, and every sharp-edge vertex exactly on its true edge.
#pragma once

#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

// A hole along z through the whole box, by the position of its axis. With slot_length > 0 it is a slot:
// a stadium along x, its two half circles of `radius` centred slot_length apart about (x, y), so the
// slot is 2 radius wide and slot_length + 2 radius long.
struct VerticalHole {
  double x = 0;
  double y = 0;
  double radius = 0;
  double slot_length = 0;  // mm between the centres of a slot's end circles; 0 for a round hole
};

// The box [0, size.x] × [0, size.y] × [0, size.z] minus the holes, outward-oriented and watertight,
// with edges of about edge_length. Each hole sits in an octagon of grid cells reaching
// max(2 edge_length, 0.3 radius) beyond its rim (a slot's octagon is stretched along x); throws
// std::invalid_argument when octagons would overlap or the rim would come within edge_length / 2 of a
// box side, i.e. when edge_length is too coarse for the hole layout.
TriangleMesh mesh_box_with_holes(const Vec3& size, const std::vector<VerticalHole>& holes, double edge_length);

// The same solid as a CAD system exports it (box_with_holes_cad.cpp): each plane face ear-clipped from its
// outline and hole circles alone, each bore wall a strip of 2 × segments long triangles. A hole's circle
// has `segments` points (a slot: each half circle about half as many, each straight side one segment);
// boundary_spacing > 0 also cuts the box's straight edges into pieces of about that length, which the
// ear clipping turns into fans of slivers.
TriangleMesh mesh_box_with_holes_cad(const Vec3& size, const std::vector<VerticalHole>& holes,
                                     const std::vector<int>& segments, double boundary_spacing = 0);

}  // namespace cmm::geometry
