// Status names, the summary and the merged cloud's measured points; see measurement_result.hpp.
#include "planner/measurement_result.hpp"

#include <cmath>

namespace cmm::planner {

const char* to_string(FeatureStatus status) {
  switch (status) {
    case FeatureStatus::measured: return "measured";
    case FeatureStatus::failed: return "failed";
    case FeatureStatus::not_planned: return "not_planned";
  }
  return "?";
}

ResultSummary summarise(const std::vector<EdgeResult>& edges, const std::vector<HoleResult>& holes) {
  ResultSummary s;
  s.edge_points = static_cast<int>(edges.size());
  double sum_squares = 0;
  for (const EdgeResult& e : edges) {
    s.edges_failed += e.status == FeatureStatus::failed;
    s.edges_not_planned += e.status == FeatureStatus::not_planned;
    if (e.status != FeatureStatus::measured) continue;
    ++s.edges_measured;
    const double deviation = std::abs(e.deviation.signed_mm);
    sum_squares += deviation * deviation;
    if (s.max_deviation_id < 0 || deviation > s.max_deviation_mm) s.max_deviation_mm = deviation, s.max_deviation_id = e.id;
    if (s.worst_sigma_id < 0 || e.scan->sigma_mm > s.worst_sigma_mm) s.worst_sigma_mm = e.scan->sigma_mm, s.worst_sigma_id = e.id;
  }
  if (s.edges_measured > 0) s.rms_deviation_mm = std::sqrt(sum_squares / s.edges_measured);
  s.holes = static_cast<int>(holes.size());
  for (const HoleResult& h : holes) {
    s.holes_failed += h.status == FeatureStatus::failed;
    s.holes_not_planned += h.status == FeatureStatus::not_planned;
    if (h.status != FeatureStatus::measured) continue;
    ++s.holes_measured;
    s.max_centre_deviation_mm = std::max(s.max_centre_deviation_mm, h.centre_deviation_mm);
    s.max_diameter_deviation_mm = std::max(s.max_diameter_deviation_mm, std::abs(h.diameter_deviation_mm));
  }
  return s;
}

std::vector<MeasuredPoint> measured_points_in_scan(const MeasurementResult& result) {
  std::vector<MeasuredPoint> points;
  for (const EdgeResult& e : result.edges)
    if (e.scan) points.push_back(*e.scan);
  for (const HoleResult& h : result.holes) points.insert(points.end(), h.wall_points.begin(), h.wall_points.end());
  return points;
}

}  // namespace cmm::planner
