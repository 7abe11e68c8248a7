// The one JSON form of what a job inspects: job.submit's "inspect" and the result's copy of it
// (docs/api.md, Inspect).
#pragma once

#include <nlohmann/json.hpp>

#include "hal/description/json_fields.hpp"
#include "planner/inspection_scope.hpp"

namespace cmm::planner {

// Reads the object at `f` (missing: every feature, nothing excluded); problems are noted on f's input
// at their JSON Pointers (`/inspect/exclude/holes/1`), unknown keys included.
InspectionScope read_inspection_scope(description::JsonFields& f);

nlohmann::json to_json(const InspectionScope& scope);

}  // namespace cmm::planner
