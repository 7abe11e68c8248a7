// The inspection's part of the result JSON (docs/result.md, Inspection): the job-wide block and the
// "inspection" member of each edge point and hole.
#pragma once

#include <nlohmann/json.hpp>

#include "planner/inspection.hpp"

namespace cmm::planner {

// {"nominal", "tolerances", "inspect", "verdict", "coverage", "counts", "exclusions", "notes"}
nlohmann::json to_json(const InspectionResult& inspection);
nlohmann::json to_json(const EdgeInspection& edge);
nlohmann::json to_json(const HoleInspection& hole);
nlohmann::json to_json(const VerdictCounts& counts);

}  // namespace cmm::planner
