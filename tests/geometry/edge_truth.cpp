// Brute force on purpose: test truth must be obviously right, and the parts are small.
#include "edge_truth.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace cmm::geometry::testing {

double covered_fraction(const AnalyticPart& part, const FeatureModel& model, double reach) {
  std::vector<Vec3> points;
  for (const EdgePoint& p : model.points)
    if (p.kind != EdgeKind::boundary) points.push_back(p.position);
  double total = 0, covered = 0;
  for (const TrueEdge& edge : part.sharp_edges) {
    const int n = static_cast<int>(edge.samples.size());
    for (int i = 0; i + (edge.closed ? 0 : 1) < n; ++i) {
      const Vec3 a = edge.samples[i].position, b = edge.samples[(i + 1) % n].position;
      const Vec3 mid = 0.5 * (a + b);
      const double length = (b - a).norm();
      total += length;
      for (const Vec3& p : points)
        if ((p - mid).norm() <= reach) {
          covered += length;
          break;
        }
    }
  }
  return total > 0 ? covered / total : 1.0;
}

double angle_deg(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
}

}  // namespace cmm::geometry::testing
