// The result as two CSV tables for spreadsheets (docs/result.md): one row per edge point, one per
// hole. RFC 4180 quoting, '\n' line ends, a header row, mm with 6 decimals, empty cells for no value.
#pragma once

#include <string>

#include "planner/measurement_result.hpp"

namespace cmm::planner {

// id,kind,method,status,x_S,y_S,z_S,x_M,y_M,z_M,deviation_mm,sigma_mm,nominal_deviation_mm,uncertainty_mm,
// tolerance_lower_mm,tolerance_upper_mm,verdict,reason (the five inspection cells empty without a nominal)
std::string to_csv(const MeasurementResult& result);

// id,status,x_S,y_S,z_S,x_M,y_M,z_M,diameter_mm,nominal_diameter_mm,diameter_deviation_mm,
// centre_deviation_mm,roundness_mm,centre_sigma_mm,diameter_sigma_mm, then diameter_ and position_ each
// {nominal_deviation_mm (position: position_mm), uncertainty_mm, lower_mm, upper_mm, verdict}, verdict, reason
std::string holes_to_csv(const MeasurementResult& result);

}  // namespace cmm::planner
