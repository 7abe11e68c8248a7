// The whole offline plan of one job: every edge point's and bore's touches, checked against the
// reference mesh in M, ordered into a move program with its time estimate.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/cancellation.hpp"
#include "geometry/feature_model.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/move_program.hpp"
#include "planner/touch_planning.hpp"

namespace cmm::planner {

struct MeasurementPlan {
  std::vector<EdgePlan> edges;  // one per model point, in the model's order
  std::vector<BorePlan> bores;  // one per model hole
  MoveProgram program;          // every planned touch, ids unique, in machine order
  double clearance_z = 0;       // the travel plane actually used, M
  double floor_z = 0;           // table or plate top the stylus must stay above, M
  std::vector<std::string> notes;
};

struct MeasurementPlanOptions {
  TouchPlanOptions touch;
  double clearance_gap_mm = 5;  // the travel plane is at least this far above the part's top and the ball
  int threads = 0;              // 0: one per hardware thread
  // The tips the plan may use, the first the job's primary: an edge point goes to the first that can
  // measure it, a bore to the one with the largest ball that can (the largest ball a feature allows
  // averages the most roughness and keeps the shaft clear: the stylus makers' rule). Each tip's radius
  // is the machine's for it; touch.radius is not used then. Empty: the active tip alone, at touch.radius.
  std::vector<std::string> tips;
  geometry::CancelCheck cancel;  // polled between edge points; plan_measurement then throws geometry::Cancelled
};

// `mesh` is the reference mesh in S, the one the model was extracted from.
MeasurementPlan plan_measurement(const geometry::FeatureModel& model, const geometry::TriangleMesh& mesh,
                                 const Eigen::Isometry3d& T_M_S, const description::MachineDescription& machine,
                                 const MeasurementPlanOptions& options);

}  // namespace cmm::planner
