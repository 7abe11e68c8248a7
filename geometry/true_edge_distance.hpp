// How far a point is from an analytic part's true sharp edges: the yardstick that the tests and
// cmm-truth hold measured and extracted edge points against.
#pragma once

#include "geometry/analytic_parts.hpp"

namespace cmm::geometry {

struct NearestTrueEdge {
  int edge = -1;
  double distance = 1e300;
  TrueEdgeSample at;  // interpolated between the two nearest samples
};

// Brute force over every sample segment, on purpose: truth must be obviously right, the parts are small.
NearestTrueEdge nearest_true_edge(const AnalyticPart& part, const Vec3& p);

}  // namespace cmm::geometry
