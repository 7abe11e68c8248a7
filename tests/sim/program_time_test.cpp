// The planner's machine-time estimate against the simulator's clock: a 200-touch program planned on
// the case-3 block, run motion by motion on the simulated machine that holds the same block.
#include <gtest/gtest.h>

#include "geometry/analytic_parts.hpp"
#include "geometry/feature_model.hpp"
#include "planner/measurement_plan.hpp"
#include "sim/simulated_cmm.hpp"

namespace cmm {
namespace {

TEST(ProgramTime, PlannerEstimateAgreesWithTheSimulatorClock) {
  sim::SimulatedCmm cmm(CMMD_SOURCE_DIR);
  cmm.configure({{"part", {{"analytic", "case3_block"}, {"edge_length_mm", 1}}}, {"seed", 3}});
  cmm.connect();
  cmm.enable();
  const sim::SimConfig config = sim::sim_config_from_json({{"part", {{"analytic", "case3_block"}, {"edge_length_mm", 1}}}});

  // The reference model is the true block itself (noise-free), in its own frame S.
  const geometry::TriangleMesh mesh = geometry::make_case3_block(1).mesh;
  geometry::FeatureModelOptions features;
  features.spacing = 4;
  const Eigen::Isometry3d T_M_S = config.T_M_P * config.T_P_Part;
  planner::MeasurementPlanOptions options;
  options.touch.radius = 1;
  options.touch.delta = 0.1;
  const planner::MeasurementPlan full =
      planner::plan_measurement(geometry::extract_features(mesh, features), mesh, T_M_S, config.machine, options);
  ASSERT_GE(full.program.touches.size(), 200u);
  std::vector<planner::Touch> touches(full.program.touches.begin(), full.program.touches.begin() + 200);
  const planner::MoveProgram program =
      planner::build_program(touches, config.machine, full.program.home, full.program.clearance_z);

  cmm.home();
  cmm.move({program.home, 0});
  const double t0 = cmm.status().t_s;
  int contacts = 0;
  for (const planner::Motion& m : program.motions) {  // each one command, as cmmd sends it
    if (m.kind != planner::MotionKind::probe) {
      cmm.move({m.to, m.speed_mm_s});
      continue;
    }
    hal::ProbeMove p;
    p.start = m.from;
    p.direction = m.direction;
    p.max_travel_mm = m.max_travel_mm;
    p.min_travel_mm = m.min_travel_mm;
    p.speed_mm_s = m.speed_mm_s;
    p.retract_mm = m.retract_mm;
    contacts += cmm.probe(p).contact;
  }
  const double machine_s = cmm.status().t_s - t0;
  EXPECT_EQ(contacts, 200);
  EXPECT_NEAR(machine_s / program.time_s, 1.0, 0.01) << "simulator " << machine_s << " s, estimate " << program.time_s << " s";
  RecordProperty("simulator_s", std::to_string(machine_s));
  RecordProperty("estimate_s", std::to_string(program.time_s));
  std::printf("200 touches: simulator %.2f s, planner estimate %.2f s, ratio %.4f\n", machine_s, program.time_s,
              machine_s / program.time_s);
}

}  // namespace
}  // namespace cmm
