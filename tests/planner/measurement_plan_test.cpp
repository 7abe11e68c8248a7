// plan_measurement as a whole: a cancel is heard between its steps and between edge points (issue
// 13, D3: a job.cancel during planning ends it within seconds); a plan over two tips gives each
// feature the tip that reaches it and changes tips once, in the program, the estimate and DMIS.
#include "planner/measurement_plan.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <map>
#include <sstream>

#include "geometry/analytic_parts.hpp"
#include "planner/dmis_export.hpp"

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

TEST(MeasurementPlan, TwoTipsMeasureTheEdgesWithTheFirstAndTheBoresWithTheLargerBallChangingOnce) {
  const geometry::TriangleMesh mesh = geometry::make_case3_block(1.0).mesh;
  geometry::FeatureModelOptions features;
  features.spacing = 4;
  const geometry::FeatureModel model = geometry::extract_features(mesh, features);
  const description::MachineDescription machine = description::default_machine();  // T1 r 1, T2 r 2.5 on a 40 mm shaft
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  T_M_S.translation() = Eigen::Vector3d(200, 200, 0);
  MeasurementPlanOptions options;
  options.tips = {"T1", "T2"};
  const MeasurementPlan both = plan_measurement(model, mesh, T_M_S, machine, options);
  options.tips = {"T1"};
  const MeasurementPlan t1 = plan_measurement(model, mesh, T_M_S, machine, options);

  int t1_bores = 0, bores = 0;
  for (const BorePlan& b : t1.bores) t1_bores += b.planned;
  for (const BorePlan& b : both.bores) {
    if (!b.planned) continue;
    ++bores;
    EXPECT_EQ(b.tip, "T2") << "hole " << b.hole;
    EXPECT_EQ(b.radius_mm, 2.5);
  }
  EXPECT_GT(bores, t1_bores) << "T2's longer shaft reaches bores T1's does not";
  EXPECT_EQ(bores, 5);
  for (std::size_t i = 0; i < both.edges.size(); ++i) {
    if (t1.edges[i].method == EdgeMethod::none) continue;
    EXPECT_EQ(both.edges[i].tip, "T1") << "edge point " << both.edges[i].edge_point << ": T1 reaches it";
  }
  // The program: T1's touches, one change, T2's; the change rises so T2's ball (20 mm lower) clears.
  std::map<std::string, int> changes;
  std::string tip = "T1";
  for (const Motion& m : both.program.motions) {
    if (m.kind == MotionKind::change_tip) {
      ++changes[m.tip];
      EXPECT_NEAR(m.from.z() - m.to.z(), 20, 1e-9);
      EXPECT_GE(m.to.z(), both.program.clearance_z - 1e-9);
      EXPECT_EQ(m.time_s, tip_change_s);
      tip = m.tip;
    }
    if (m.kind == MotionKind::probe) {
      const auto t = std::find_if(both.program.touches.begin(), both.program.touches.end(),
                                  [&](const Touch& x) { return x.id == m.touch; });
      ASSERT_NE(t, both.program.touches.end());
      EXPECT_EQ(t->tip, tip) << "touch " << m.touch << " runs with the wrong tip active";
    }
  }
  EXPECT_EQ(changes, (std::map<std::string, int>{{"T2", 1}}));
  // DMIS: both sensors defined, T2 selected where the program changes.
  std::ostringstream dmis;
  write_dmis(dmis, both.program, machine, dmis_features(both.program, model.holes), {});
  EXPECT_NE(dmis.str().find("S(T1)=SNSDEF"), std::string::npos);
  EXPECT_NE(dmis.str().find("S(T2)=SNSDEF/PROBE,FIXED,CART,0.0000,0.0000,-20.0000"), std::string::npos);
  EXPECT_NE(dmis.str().find("SNSLCT/S(T2)"), std::string::npos);
}

}  // namespace
}  // namespace cmm::planner
