// The one JSON form of a job's tolerances: job.submit's "tolerances", cmmd.json's defaults and the
// result's copy are all this layout (docs/api.md, Tolerances).
#pragma once

#include <nlohmann/json.hpp>

#include "hal/description/json_fields.hpp"
#include "planner/inspection.hpp"

namespace cmm::planner {

// Reads the object at `f` over `defaults` (a missing key keeps its default); problems are noted on f's
// input at their JSON Pointers (`/tolerances/holes/3/diameter_mm/1`), unknown keys included.
Tolerances read_tolerances(description::JsonFields& f, const Tolerances& defaults);

nlohmann::json to_json(const Tolerances& tolerances);

}  // namespace cmm::planner
