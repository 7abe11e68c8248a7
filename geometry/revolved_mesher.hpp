// Meshes a closed surface of revolution about the z axis (the bicone, the hemisphere-cone) from points
// of its profile: one ring of vertices per profile point, so ridges of the profile become exact mesh rings.
#pragma once

#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

// `profile` holds (r, z) points exactly on the true profile, about edge_length apart, from the bottom
// pole (r = 0) to the top pole (r = 0) with r > 0 in between. Each inner point becomes a ring of about
// 2πr / edge_length vertices (at least 3), each pole one vertex; the result is outward-oriented and watertight.
TriangleMesh mesh_revolved_profile(const std::vector<Eigen::Vector2d>& profile, double edge_length);

// As a CAD system exports it: every ring has the same number of segments, aligned, so a pole or apex is
// a fan of long triangles to its ring and neighbouring rings are joined by strips of quads.
TriangleMesh mesh_revolved_profile_cad(const std::vector<Eigen::Vector2d>& profile, int segments);

}  // namespace cmm::geometry
