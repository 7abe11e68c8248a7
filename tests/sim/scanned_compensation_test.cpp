// A whole plan compensated on a realistic reference: the case-3 block as the scanner sees it (vertex
// noise, the faces no view sees dropped, so its bores are open rims), touched on the true block.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "edge_truth.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/feature_model.hpp"
#include "planner/plan_compensation.hpp"
#include "sim/scanned_mesh.hpp"
#include "true_part_touches.hpp"

namespace cmm {
namespace {

TEST(ScannedCompensation, EdgePointsFromAScannedReferenceMatchTheTruth) {
  constexpr double radius = 1, sigma = 0.001;
  const geometry::AnalyticPart truth = geometry::make_case3_block(0.25);
  const sim::ScannedMesh scanned = sim::synthesize_scanned_mesh(geometry::make_case3_block(1.0).mesh, {.seed = 7});
  geometry::FeatureModelOptions features;
  features.spacing = 4;
  const geometry::FeatureModel model = geometry::extract_features(scanned.mesh, features);
  const Eigen::Isometry3d T_M_S = planner::testing::tilted_machine_pose();
  description::MachineDescription machine = description::default_machine();
  machine.tips.front().ball_radius_mm = radius;
  machine.tips.front().shaft_length_mm = 60;
  planner::MeasurementPlanOptions options;
  options.touch.radius = radius;
  options.touch.delta = 0.2;  // 4σ of the scan's 0.05 mm vertex noise
  const planner::MeasurementPlan plan = planner::plan_measurement(model, scanned.mesh, T_M_S, machine, options);
  const planner::testing::TrueTouches touches =
      planner::testing::touch_true_part(truth.mesh, T_M_S, plan, radius, sigma, 99);
  const planner::MeasurementResult result = planner::compensate_plan(model, plan, T_M_S, touches.outcomes, {radius, sigma});

  EXPECT_EQ(touches.missed, 0);
  double worst = 0;
  std::map<std::string, int> failures;
  for (const planner::EdgeResult& e : result.edges) {
    if (e.status == planner::FeatureStatus::failed) ++failures[e.reason.substr(0, 120)];
    if (e.status != planner::FeatureStatus::measured) continue;
    const double error = geometry::testing::nearest_true_edge(truth, e.scan->position).distance;
    worst = std::max(worst, error);
    EXPECT_LE(error, 0.010) << "point " << e.id << " (" << planner::to_string(e.method) << ", "
                            << geometry::to_string(e.kind) << "): " << error * 1e3 << " um off the true edge";
  }
  for (const auto& [reason, count] : failures) ADD_FAILURE() << count << " x " << reason;
  double worst_diameter = 0;
  for (const planner::HoleResult& h : result.holes) {
    if (h.status != planner::FeatureStatus::measured) continue;
    double error = 1e300;  // against the true hole whose axis is nearest the measured centre
    for (const geometry::TrueHole& t : truth.holes) {
      const geometry::Vec3 v = h.scan->centre - t.centre;
      if ((v - v.dot(t.axis) * t.axis).norm() < 1) error = h.scan->diameter_mm - 2 * t.radius;
    }
    worst_diameter = std::max(worst_diameter, std::abs(error));
    EXPECT_LE(std::abs(error), 0.005) << "hole " << h.id;  // the 0.25 mm truth's flats: up to 3.2 µm on Ø10
  }
  const planner::ResultSummary& s = result.summary;
  std::printf("scanned case-3 block: %d edge points, %d measured, %d failed, %d not planned; worst error %.4f um, "
              "worst sigma %.4f um; holes %d measured (worst diameter error %.4f um), %d not planned; rms deviation from the "
              "scan %.4f mm\n",
              s.edge_points, s.edges_measured, s.edges_failed, s.edges_not_planned, worst * 1e3, s.worst_sigma_mm * 1e3,
              s.holes_measured, worst_diameter * 1e3, s.holes_not_planned, s.rms_deviation_mm);
  EXPECT_GT(s.edges_measured, 100);
  EXPECT_EQ(s.edges_failed, 0);
}

}  // namespace
}  // namespace cmm
