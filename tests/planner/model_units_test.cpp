// The model against the plate it stands on (planner/model_units.hpp): a model in inches, centimetres
// or metres is refused naming the factor, the right one stands, one off the plate says so (issue 34).
#include "planner/model_units.hpp"

#include <cmath>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "geometry/analytic_parts.hpp"

namespace cmm::planner {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// The demo's set-up (config/samples/demo_sim.json): S is the part's own frame, the case-3 block
// stands on the default plate at (55, 25) turned by −4°, so T_S_P is that pose's inverse.
Eigen::Isometry3d demo_T_S_P() {
  Eigen::Isometry3d T_P_Part = Eigen::Isometry3d::Identity();
  T_P_Part.linear() = Eigen::AngleAxisd(-4 * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_P_Part.translation() = Eigen::Vector3d(55, 25, 0);
  return T_P_Part.inverse();
}

geometry::Points block(double times = 1) { return geometry::make_analytic_part("case3_block", 2).mesh.vertices * times; }

ModelUnits check(const geometry::Points& points, double scale = 1, bool corners = true) {
  return check_model_units(points, scale, "part.stl (scale " + std::to_string(scale) + ")", description::default_plate(),
                           corners ? std::optional(demo_T_S_P()) : std::nullopt);
}

TEST(ModelUnits, TheRightModelStandsOnThePlate) {
  const ModelUnits u = check(block());
  EXPECT_TRUE(u.stands) << u.problem;
  EXPECT_EQ(u.problem, "");
  EXPECT_TRUE(u.corners_known);
  EXPECT_NEAR(u.extent_mm.x(), 88, 0.5);
  EXPECT_NEAR(u.extent_mm.y(), 95, 0.5);
  EXPECT_NEAR(u.extent_mm.z(), 41, 0.5);
}

TEST(ModelUnits, AModelInInchesIsRefusedNamingTheFactor) {
  const ModelUnits u = check(block(1 / 25.4));
  EXPECT_FALSE(u.stands);
  ASSERT_TRUE(u.factor);
  EXPECT_DOUBLE_EQ(*u.factor, 25.4);
  EXPECT_THAT(u.problem, HasSubstr("the model is 25.4× smaller than the plate it stands on: a model in inches? use --scale 25.4"));
  EXPECT_THAT(u.problem, HasSubstr("--units-checked"));
  EXPECT_THAT(u.problem, HasSubstr("3.465 × 3.740 × 1.614 mm"));
}

TEST(ModelUnits, AModelInCentimetresOrMetresIsRefusedNamingItsFactor) {
  const ModelUnits cm = check(block(0.1));
  ASSERT_TRUE(cm.factor) << cm.problem;
  EXPECT_DOUBLE_EQ(*cm.factor, 10);
  EXPECT_THAT(cm.problem, HasSubstr("10× smaller than the plate it stands on: a model in centimetres? use --scale 10"));
  const ModelUnits m = check(block(0.001));
  ASSERT_TRUE(m.factor) << m.problem;
  EXPECT_DOUBLE_EQ(*m.factor, 1000);
  EXPECT_THAT(m.problem, HasSubstr("1000× smaller than the plate it stands on: a model in metres? use --scale 1000"));
}

TEST(ModelUnits, TheSuggestedScaleIsTheGivenOneTimesTheFactor) {
  // A model in tenths of an inch given scale 2.54 is still ten times too small.
  const ModelUnits u = check(block(0.1), 2.54);
  ASSERT_TRUE(u.factor);
  EXPECT_THAT(u.problem, HasSubstr("use --scale 25.4"));
}

TEST(ModelUnits, AModelScaledTooMuchIsRefusedAsTooLarge) {
  const ModelUnits u = check(block(25.4), 25.4);
  ASSERT_TRUE(u.factor) << u.problem;
  EXPECT_DOUBLE_EQ(*u.factor, 1 / 25.4);
  EXPECT_THAT(u.problem, HasSubstr("25.4× larger than the plate it stands on"));
  EXPECT_THAT(u.problem, HasSubstr("use --scale 1 "));
}

TEST(ModelUnits, AModelOffThePlateThatNoFactorFixesGetsItsOwnMessage) {
  geometry::Points off = block();
  off.col(0).array() += 400;  // beyond corner 2's side in S, whatever the unit
  const ModelUnits u = check(off);
  EXPECT_FALSE(u.stands);
  EXPECT_FALSE(u.factor);
  EXPECT_THAT(u.problem, HasSubstr("does not stand on the plate inside its corners"));
  EXPECT_THAT(u.problem, HasSubstr("beyond the plate's side from corner 2 to corner 3"));
  EXPECT_THAT(u.problem, HasSubstr("no unit factor"));
  EXPECT_THAT(u.problem, Not(HasSubstr("use --scale")));
}

TEST(ModelUnits, ATinyPartOnThePlateIsRefusedUntilTheCallerIsToldItIsRight) {
  // 3 mm across, standing in the middle of the plate: no factor puts the part there too, so no
  // factor is named; the request's override (units_checked, an explicit scale) is the daemon's.
  geometry::Points tiny = block(3.0 / 95);
  tiny.col(0).array() += 40;
  tiny.col(1).array() += 40;
  const ModelUnits u = check(tiny);
  EXPECT_FALSE(u.stands);
  EXPECT_THAT(u.problem, HasSubstr("only 3.000 mm across"));
  EXPECT_THAT(u.problem, HasSubstr("--units-checked"));
}

TEST(ModelUnits, AScansStraysDoNotMoveThePart) {
  geometry::Points scan = block();
  for (int i = 0; i < 3; ++i) scan.row(i * 100) << 900, -700, 300;  // a few stray returns far away
  const ModelUnits u = check(scan);
  EXPECT_TRUE(u.stands) << u.problem;
}

TEST(ModelUnits, WithoutCornersOnlyTheSizeIsCheckedAndTheNotesSaySo) {
  const ModelUnits right = check(block(), 1, false);
  EXPECT_TRUE(right.stands) << right.problem;
  EXPECT_FALSE(right.corners_known);
  ASSERT_FALSE(right.notes.empty());
  EXPECT_THAT(right.notes.front(), HasSubstr("position on the plate was not checked"));
  const ModelUnits inch = check(block(1 / 25.4), 1, false);
  ASSERT_TRUE(inch.factor) << inch.problem;
  EXPECT_DOUBLE_EQ(*inch.factor, 25.4);
  EXPECT_THAT(inch.problem, HasSubstr("is a plausible size for the plate"));
}

}  // namespace
}  // namespace cmm::planner
