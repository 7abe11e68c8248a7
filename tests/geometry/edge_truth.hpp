// Test support: compares extracted edge points and holes with an analytic part's exact truth
// (distance to the true edges, normals there, coverage of the true edge length).
#pragma once

#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/true_edge_distance.hpp"

namespace cmm::geometry::testing {

// The distance to the true edges lives in geometry (cmm-truth uses it too).
using geometry::NearestTrueEdge;
using geometry::nearest_true_edge;

// Fraction of the true sharp-edge length within `reach` of some sharp-edge or hole-rim point.
double covered_fraction(const AnalyticPart& part, const FeatureModel& model, double reach);

double angle_deg(const Vec3& a, const Vec3& b);

}  // namespace cmm::geometry::testing
