// Brute force on purpose: test truth must be obviously right, and the parts are small.
#include "edge_truth.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace cmm::geometry::testing {

NearestTrueEdge nearest_true_edge(const AnalyticPart& part, const Vec3& p) {
  NearestTrueEdge best;
  for (int e = 0; e < static_cast<int>(part.sharp_edges.size()); ++e) {
    const auto& samples = part.sharp_edges[e].samples;
    const int n = static_cast<int>(samples.size());
    const int segments = part.sharp_edges[e].closed ? n : n - 1;
    for (int i = 0; i < segments; ++i) {
      const TrueEdgeSample& a = samples[i];
      const TrueEdgeSample& b = samples[(i + 1) % n];
      const Vec3 ab = b.position - a.position;
      const double t = std::clamp((p - a.position).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
      const double d = (a.position + t * ab - p).norm();
      if (d < best.distance) {
        best.edge = e;
        best.distance = d;
        best.at.position = a.position + t * ab;
        best.at.n_up = ((1 - t) * a.n_up + t * b.n_up).normalized();
        best.at.n_down = ((1 - t) * a.n_down + t * b.n_down).normalized();
      }
    }
  }
  return best;
}

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
