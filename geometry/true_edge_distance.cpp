// Distance from a point to the nearest true edge of an analytic part, for holding measured edge
// points against the truth.
#include "geometry/true_edge_distance.hpp"

#include <algorithm>

namespace cmm::geometry {

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

}  // namespace cmm::geometry
