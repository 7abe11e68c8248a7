// From a whole plan's touch results to the job's measurement: each edge point and bore compensated
// by the method it was planned with; one feature's bad touches fail that feature, never the job.
#pragma once

#include <map>

#include <Eigen/Geometry>

#include "geometry/feature_model.hpp"
#include "planner/measurement_plan.hpp"
#include "planner/measurement_result.hpp"

namespace cmm::planner {

// What the machine reported for one planned touch (the planner's view of hal::TouchResult).
struct TouchOutcome {
  bool contact = false;
  Vec3 centre = Vec3::Zero();  // ball centre at the trigger, M
};

struct CompensationOptions {
  double ball_radius_mm = 1;       // the active tip's qualified radius
  double trigger_sigma_mm = 0.001; // 1-σ of a trigger centre, per axis
};

// `touches` is keyed by the plan's touch ids; ids the plan does not know are ignored (and counted
// in the notes). The model and plan must belong together (same edge points and holes, in order):
// anything else throws std::invalid_argument, since no single feature is to blame.
MeasurementResult compensate_plan(const geometry::FeatureModel& model, const MeasurementPlan& plan,
                                  const Eigen::Isometry3d& T_M_S, const std::map<int, TouchOutcome>& touches,
                                  const CompensationOptions& options);

}  // namespace cmm::planner
