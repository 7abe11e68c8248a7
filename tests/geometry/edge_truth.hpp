// Test support: compares extracted edge points and holes with an analytic part's exact truth
// (distance to the true edges, normals there, coverage of the true edge length).
#pragma once

#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/feature_model.hpp"

namespace cmm::geometry::testing {

struct NearestTrueEdge {
  int edge = -1;
  double distance = 1e300;
  TrueEdgeSample at;  // interpolated between the two nearest samples
};

NearestTrueEdge nearest_true_edge(const AnalyticPart& part, const Vec3& p);

// Fraction of the true sharp-edge length within `reach` of some sharp-edge or hole-rim point.
double covered_fraction(const AnalyticPart& part, const FeatureModel& model, double reach);

double angle_deg(const Vec3& a, const Vec3& b);

}  // namespace cmm::geometry::testing
