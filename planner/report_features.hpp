// The report's table of features: one row per edge point, two per hole (diameter and position),
// with nominal, measured, deviation, tolerance, U and verdict (against the nominal when the job had
// one; otherwise the deviation against the scan and the measurement status).
#pragma once

#include <string>

#include "planner/measurement_result.hpp"

namespace cmm::planner {

// The <table> element, every text escaped.
std::string feature_table_html(const MeasurementResult& result);

}  // namespace cmm::planner
