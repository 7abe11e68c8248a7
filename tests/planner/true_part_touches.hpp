// Test support: a plan's touches as a machine holding the TRUE part would report them — each probe
// motion swept exactly against the true mesh placed in M, the trigger centre with seeded noise.
#pragma once

#include <cstdint>
#include <map>

#include <Eigen/Geometry>

#include "geometry/mesh.hpp"
#include "planner/measurement_plan.hpp"
#include "planner/plan_compensation.hpp"

namespace cmm::planner::testing {

struct TrueTouches {
  std::map<int, TouchOutcome> outcomes;  // by touch id; a miss reports no contact at the search's end
  int swept = 0, missed = 0;
};

// `true_part` is in S; every edge and bore touch of `plan` is swept against it through T_M_S, with
// Gaussian noise of `sigma_mm` per axis on each centre.
TrueTouches touch_true_part(const geometry::TriangleMesh& true_part, const Eigen::Isometry3d& T_M_S,
                            const MeasurementPlan& plan, double radius_mm, double sigma_mm, std::uint64_t seed);

// The scan frame turned 30° about z, tilted 0.5° and moved into the default machine's travel box,
// as a real registration would leave it.
Eigen::Isometry3d tilted_machine_pose();

}  // namespace cmm::planner::testing
