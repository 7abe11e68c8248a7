// plan_measurement as a whole: a cancel is heard between its steps and between edge points (issue
// 13, D3: a job.cancel during planning ends it within seconds).
#include "planner/measurement_plan.hpp"

#include <gtest/gtest.h>

#include <atomic>

#include "geometry/analytic_parts.hpp"

namespace cmm::planner {
namespace {

TEST(MeasurementPlan, ACancelStopsPlanningAtItsNextStep) {
  const geometry::TriangleMesh mesh = geometry::make_case3_block(1.0).mesh;
  geometry::FeatureModelOptions features;
  features.spacing = 1;
  const geometry::FeatureModel model = geometry::extract_features(mesh, features);
  description::MachineDescription machine = description::default_machine();
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  T_M_S.translation() = Eigen::Vector3d(200, 200, 0);
  MeasurementPlanOptions options;
  options.touch.radius = machine.tip().ball_radius_mm;
  options.threads = 2;
  std::atomic<int> asked{0};
  options.cancel = {[&] { return ++asked < 0; }};
  const MeasurementPlan plan = plan_measurement(model, mesh, T_M_S, machine, options);
  EXPECT_FALSE(plan.program.touches.empty());
  const int steps = asked.load();
  EXPECT_GT(steps, static_cast<int>(model.points.size() / 64)) << "not asked between blocks of edge points";
  for (int at : {0, 1, steps / 2, steps - 1}) {
    std::atomic<int> count{0};
    options.cancel = {[&, at] { return count++ >= at; }};
    EXPECT_THROW(plan_measurement(model, mesh, T_M_S, machine, options), geometry::Cancelled) << "at " << at;
  }
}

}  // namespace
}  // namespace cmm::planner
