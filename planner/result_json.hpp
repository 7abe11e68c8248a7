// The result JSON ("cmmd.result/1", docs/result.md): what a job measured, for the daemon to store
// and serve. A plain object, so the daemon can add its registration and traceability fields to it.
#pragma once

#include <nlohmann/json.hpp>

#include "planner/measurement_result.hpp"

namespace cmm::planner {

inline constexpr const char* result_schema_id = "cmmd.result/1";

// Top level: schema, units, frame, T_M_S, probe, summary, edge_points, holes, notes. Vectors are
// [x, y, z] in mm; a feature that was not measured has null positions and deviations.
nlohmann::json to_json(const MeasurementResult& result);

}  // namespace cmm::planner
