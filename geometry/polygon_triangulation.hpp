// Ear-clipping triangulation of a plane polygon with holes, as CAD systems cut a planar face: every
// triangle's corners are polygon vertices, so a face of few vertices becomes a few (often long) triangles.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

namespace cmm::geometry {

using Polygon2d = std::vector<Eigen::Vector2d>;

// `outer` runs counter-clockwise, each hole clockwise, none touching another. The triangles index the
// points of outer, then of each hole in turn, and run counter-clockwise. Collinear points stay corners
// (a neighbouring face shares them). Throws std::invalid_argument when no ear is left (a polygon that
// crosses itself or a hole outside the outline).
std::vector<std::array<int, 3>> triangulate_polygon(const Polygon2d& outer, const std::vector<Polygon2d>& holes);

}  // namespace cmm::geometry
