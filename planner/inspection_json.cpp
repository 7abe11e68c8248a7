// Verdicts, deviations and the nominal's placement as result JSON.
#include "planner/inspection_json.hpp"

#include "hal/description/eigen_json.hpp"
#include "planner/inspection_scope_json.hpp"
#include "planner/tolerances_json.hpp"

namespace cmm::planner {

namespace {

using description::vec3_json;
using nlohmann::json;

json characteristic_json(const Characteristic& c) {
  const bool measured = judged(c.verdict);
  return {{"deviation_mm", measured ? json(c.deviation_mm) : json(nullptr)},
          {"uncertainty_mm", measured ? json(c.uncertainty_mm) : json(nullptr)},
          {"tolerance_mm", json::array({c.zone.lower_mm, c.zone.upper_mm})},
          {"verdict", to_string(c.verdict)}};
}

json optional_vec3(const std::optional<Vec3>& v) { return v ? vec3_json(*v) : json(nullptr); }
json reason_json(const std::string& reason) { return reason.empty() ? json(nullptr) : json(reason); }

}  // namespace

json to_json(const VerdictCounts& c) {
  return {{"pass", c.pass},
          {"fail", c.fail},
          {"undecided", c.undecided},
          {"not_measured", c.not_measured},
          {"excluded", c.excluded}};
}

json to_json(const EdgeInspection& e) {
  json j = characteristic_json(e.profile);
  j["nominal_S"] = optional_vec3(e.nominal_S);
  j["reason"] = reason_json(e.reason);
  return j;
}

json to_json(const HoleInspection& h) {
  return {{"nominal_centre_S", optional_vec3(h.nominal_centre_S)},
          {"nominal_axis_S", optional_vec3(h.nominal_axis_S)},
          {"nominal_diameter_mm", h.nominal_centre_S ? json(h.nominal_diameter_mm) : json(nullptr)},
          {"diameter", characteristic_json(h.diameter)},
          {"position", characteristic_json(h.position)},
          {"verdict", to_string(worse(h.diameter.verdict, h.position.verdict))},
          {"reason", reason_json(h.reason)}};
}

json to_json(const InspectionResult& inspection) {
  const NominalPlacement& n = inspection.nominal;
  json exclusions = json::array();
  for (const Exclusion& e : inspection.exclusions)
    exclusions.push_back({{"reason", e.reason}, {"edge_points", e.edge_points}, {"holes", e.holes}});
  return {{"nominal", {{"model", n.model},
                       {"method", n.method},
                       {"T_S_N", description::transform_json(n.T_S_N)},
                       {"iterations", n.iterations},
                       {"converged", n.converged},
                       {"rms_mm", n.rms_mm},
                       {"overlap", n.overlap}}},
          {"tolerances", to_json(inspection.tolerances)},
          {"inspect", to_json(inspection.scope)},
          {"verdict", to_string(inspection.verdict)},
          {"coverage", coverage_text(inspection)},
          {"counts", {{"edge_points", to_json(inspection.edge_counts)}, {"holes", to_json(inspection.hole_counts)}}},
          {"exclusions", std::move(exclusions)},
          {"notes", inspection.notes}};
}

}  // namespace cmm::planner
