// How the report writes numbers and verdicts: lengths in mm with 4 decimals (µm visible), signs
// shown on deviations, one label and one CSS class per verdict.
#pragma once

#include <string>

#include "geometry/mesh.hpp"
#include "planner/inspection.hpp"

namespace cmm::planner {

std::string report_mm(double mm);            // "12.3456"
std::string report_signed_mm(double mm);     // "+0.0123", "-0.0123"
std::string report_point(const geometry::Vec3& p);  // "x, y, z" in mm
std::string report_zone(const ToleranceZone& zone);  // "±0.1000" or "-0.0500 / +0.0800"

const char* verdict_label(Verdict verdict);  // "pass", "fail", "undecided", "not measured"
const char* verdict_class(Verdict verdict);  // "v-pass", "v-fail", "v-undecided", "v-not-measured"

}  // namespace cmm::planner
