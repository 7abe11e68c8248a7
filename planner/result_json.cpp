// Serialises a MeasurementResult; the field list is docs/result.md's.
#include "planner/result_json.hpp"

#include "hal/description/eigen_json.hpp"
#include "planner/inspection_json.hpp"

namespace cmm::planner {

namespace {

using description::vec3_json;
using nlohmann::json;

json matrix(const Eigen::Matrix3d& m) {
  json rows = json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2)});
  return rows;
}

json reason(const std::string& text) { return text.empty() ? json(nullptr) : json(text); }

json point_json(const MeasuredPoint& p) {
  return {{"position", vec3_json(p.position)},
          {"tangent", vec3_json(p.tangent)},
          {"covariance_mm2", matrix(p.covariance)}};
}

json edge_json(const EdgeResult& e) {
  json j = {{"id", e.id},
            {"kind", geometry::to_string(e.kind)},
            {"method", to_string(e.method)},
            {"status", to_string(e.status)},
            {"reason", reason(e.reason)},
            {"touches", e.touch_ids},
            {"tip", e.tip},
            {"reference_S", vec3_json(e.reference)},
            {"measured_S", nullptr},
            {"measured_M", nullptr},
            {"deviation_mm", nullptr},
            {"deviation", nullptr},
            {"sigma_mm", nullptr},
            {"sensitivity", nullptr},
            {"clamped", nullptr},
            {"out_of_plane_mm", nullptr},
            {"notes", json::array()}};
  if (e.status != FeatureStatus::measured) return j;
  j["measured_S"] = point_json(*e.scan);
  j["measured_M"] = point_json(*e.machine);
  j["deviation_mm"] = e.deviation.signed_mm;
  j["deviation"] = {{"vector_S", vec3_json(e.deviation.vector)},
                    {"outward_mm", e.deviation.outward_mm},
                    {"sideways_mm", e.deviation.sideways_mm}};
  j["sigma_mm"] = e.scan->sigma_mm;
  j["sensitivity"] = e.scan->sensitivity;
  j["clamped"] = e.scan->clamped;
  j["out_of_plane_mm"] = e.scan->out_of_plane_mm;
  j["notes"] = e.scan->notes;
  return j;
}

json bore_json(const BoreMeasurement& b) {
  return {{"centre", vec3_json(b.centre)}, {"axis", vec3_json(b.axis)}, {"centre_covariance_mm2", matrix(b.centre_covariance)}};
}

json hole_json(const HoleResult& h) {
  json j = {{"id", h.id},
            {"status", to_string(h.status)},
            {"reason", reason(h.reason)},
            {"touches", h.touch_ids},
            {"tip", h.tip},
            {"depth_mm", h.depth_mm},
            {"nominal", {{"centre_S", vec3_json(h.nominal_centre)}, {"axis_S", vec3_json(h.nominal_axis)},
                         {"diameter_mm", h.nominal_diameter_mm}}},
            {"measured_S", nullptr},
            {"measured_M", nullptr},
            {"diameter_mm", nullptr},
            {"roundness_mm", nullptr},
            {"rms_mm", nullptr},
            {"depth_spread_mm", nullptr},
            {"centre_sigma_mm", nullptr},
            {"diameter_sigma_mm", nullptr},
            {"residuals_mm", nullptr},
            {"centre_offset_S", nullptr},
            {"centre_deviation_mm", nullptr},
            {"diameter_deviation_mm", nullptr}};
  if (h.status != FeatureStatus::measured) return j;
  const BoreMeasurement& b = *h.scan;
  j["measured_S"] = bore_json(b);
  j["measured_M"] = bore_json(*h.machine);
  j["diameter_mm"] = b.diameter_mm;
  j["roundness_mm"] = b.roundness_mm;
  j["rms_mm"] = b.rms_mm;
  j["depth_spread_mm"] = b.depth_spread_mm;
  j["centre_sigma_mm"] = b.centre_sigma_mm;
  j["diameter_sigma_mm"] = b.diameter_sigma_mm;
  j["residuals_mm"] = b.residuals_mm;
  j["centre_offset_S"] = vec3_json(h.centre_offset);
  j["centre_deviation_mm"] = h.centre_deviation_mm;
  j["diameter_deviation_mm"] = h.diameter_deviation_mm;
  return j;
}

json id_or_null(int id) { return id < 0 ? json(nullptr) : json(id); }

json summary_json(const ResultSummary& s) {
  return {{"edge_points", {{"total", s.edge_points}, {"measured", s.edges_measured}, {"failed", s.edges_failed},
                           {"not_planned", s.edges_not_planned}}},
          {"holes", {{"total", s.holes}, {"measured", s.holes_measured}, {"failed", s.holes_failed},
                     {"not_planned", s.holes_not_planned}}},
          {"rms_deviation_mm", s.rms_deviation_mm},
          {"max_deviation_mm", s.max_deviation_mm},
          {"max_deviation_id", id_or_null(s.max_deviation_id)},
          {"worst_sigma_mm", s.worst_sigma_mm},
          {"worst_sigma_id", id_or_null(s.worst_sigma_id)},
          {"max_centre_deviation_mm", s.max_centre_deviation_mm},
          {"max_diameter_deviation_mm", s.max_diameter_deviation_mm}};
}

}  // namespace

json to_json(const MeasurementResult& result) {
  json edges = json::array(), holes = json::array();
  for (const EdgeResult& e : result.edges) edges.push_back(edge_json(e));
  for (const HoleResult& h : result.holes) holes.push_back(hole_json(h));
  // Against the nominal, beside the deviation against the scan: the two answer different questions.
  const InspectionResult* inspection = result.inspection ? &*result.inspection : nullptr;
  for (std::size_t i = 0; i < edges.size(); ++i)
    edges[i]["inspection"] = inspection && i < inspection->edges.size() ? to_json(inspection->edges[i]) : json(nullptr);
  for (std::size_t i = 0; i < holes.size(); ++i)
    holes[i]["inspection"] = inspection && i < inspection->holes.size() ? to_json(inspection->holes[i]) : json(nullptr);
  return {{"schema", result_schema_id},
          {"units", "mm"},
          {"frame", "S"},
          {"T_M_S", description::transform_json(result.T_M_S)},
          {"probe", {{"ball_radius_mm", result.ball_radius_mm}, {"trigger_sigma_mm", result.trigger_sigma_mm}}},
          {"summary", summary_json(result.summary)},
          {"edge_points", std::move(edges)},
          {"holes", std::move(holes)},
          {"inspection", inspection ? to_json(*inspection) : json(nullptr)},
          {"notes", result.notes}};
}

}  // namespace cmm::planner
