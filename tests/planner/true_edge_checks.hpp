// Test support: the true part's sharp polyline (what the real ball can meet), its corners, and angles
// measured in the true cross-section, shared by the planner's acceptance tests on the analytic parts.
#pragma once

#include <utility>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::planner::testing {

using geometry::Vec3;

using Segment = std::pair<Vec3, Vec3>;

// The true mesh's own sharp edges (dihedral over 20°). On a revolved part or a bore they are the
// circle's chords, within 0.3 µm of the circle at 0.25 mm edges: the sweep is judged against these.
std::vector<Segment> sharp_segments(const geometry::TriangleMesh& mesh);

// Where three or more sharp segments meet: the corners of the part.
std::vector<Vec3> corners_of(const std::vector<Segment>& segments);

double distance_to(const std::vector<Segment>& segments, const Vec3& p);

// Angle of a direction from `axis` within the plane of normal `plane_normal` (the direction projected
// into it first).
double angle_in_fan(const Vec3& d, const Vec3& axis, const Vec3& plane_normal);

}  // namespace cmm::planner::testing
