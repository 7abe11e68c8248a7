// Holding a job's measured features against its nominal model with the job's tolerances: one
// deviation, uncertainty and verdict per edge point and per hole characteristic (planner/inspection.hpp).
#pragma once

#include <vector>

#include "geometry/edge_point.hpp"
#include "planner/measurement_result.hpp"
#include "planner/nominal_model.hpp"

namespace cmm::planner {

// `reference_points` are the reference model's edge points by id (for their feature curves, which
// per-curve tolerances and the scope name). The result's edges and holes must be measured in S (`scan`
// set). A feature outside `scope` is `excluded` with the reason; one inside it and not measured is
// `not_measured`, and the job incomplete.
InspectionResult inspect(const MeasurementResult& result, const std::vector<geometry::EdgePoint>& reference_points,
                         const NominalModel& nominal, const Tolerances& tolerances, const NominalPlacement& placement,
                         const InspectionScope& scope = {});

// How far from a measured edge point a nominal edge is looked for: a point farther than this from
// every nominal edge is held against none (not measured, with the reason).
double nominal_edge_reach_mm(const Tolerances& tolerances, double profile_mm);

}  // namespace cmm::planner
