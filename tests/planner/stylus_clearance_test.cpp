// The stylus checks on a 40 mm cube standing on the table ([0, 40]³): each way a touch can be
// unsafe is refused with the motion that fails, and a plain touch on the top passes.
#include <gtest/gtest.h>

#include <string>

#include "geometry/analytic_parts.hpp"
#include "geometry/ball_sweep.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/stylus_clearance.hpp"

namespace cmm::planner {
namespace {

class StylusClearanceOnACube : public ::testing::Test {
 protected:
  StylusClearanceOnACube() : cube_(moved_cube()), sweeper_(cube_) { machine_ = description::default_machine(); }

  static geometry::TriangleMesh moved_cube() { return geometry::make_cube(40, 2).mesh; }

  // A touch on `surface_point` along `direction`, with the planner's run-up and overtravel.
  Touch touch(const Vec3& surface_point, const Vec3& direction) const {
    Touch t;
    t.surface_point = surface_point;
    t.direction = direction.normalized();
    t.nominal_centre = surface_point - radius_ * t.direction;
    t.start = t.nominal_centre - 1.2 * t.direction;
    t.max_travel_mm = 1.5;
    return t;
  }

  std::string refusal(const Touch& t) const { return refusal(sweeper_, t, 60); }
  std::string refusal(const geometry::BallSweeper& sweeper, const Touch& t, double clearance_z) const {
    const StylusClearance clearance(sweeper, 0, machine_, radius_, clearance_z, 0.2);
    const ClearanceCheck check = clearance.check(t);
    return check.ok ? "(clear)" : check.reason;
  }

  geometry::TriangleMesh cube_;
  geometry::BallSweeper sweeper_;
  description::MachineDescription machine_;
  double radius_ = 1;
};

TEST_F(StylusClearanceOnACube, TopFaceTouchIsClear) {
  EXPECT_EQ(refusal(touch(Vec3(20, 20, 40), -Vec3::UnitZ())), "(clear)");
}

TEST_F(StylusClearanceOnACube, EachUnsafeMotionIsNamed) {
  // Low on a wall: the ball would go below the table.
  EXPECT_NE(refusal(touch(Vec3(40, 20, 0.5), -Vec3::UnitX())).find("below the table top"), std::string::npos);
  // Mid-wall with the 20 mm shaft: the head (7 mm) hangs over the top edge while it descends.
  const std::string head = refusal(touch(Vec3(40, 20, 25), -Vec3::UnitX()));
  EXPECT_NE(head.find("probe head would meet the part descending"), std::string::npos) << head;
  // From below.
  EXPECT_NE(refusal(touch(Vec3(20, 20, 40), Vec3::UnitZ())).find("from below"), std::string::npos);
  // Aimed at the top from beside the cube: the search never meets it.
  const std::string beside = refusal(touch(Vec3(50, 20, 40), -Vec3::UnitZ()));
  EXPECT_NE(beside.find("never meets"), std::string::npos) << beside;
  // Outside the travel box.
  machine_.travel_box.max.x() = 10;
  EXPECT_NE(refusal(touch(Vec3(40, 20, 30), -Vec3::UnitX())).find("outside the travel box"), std::string::npos);
}

TEST_F(StylusClearanceOnACube, TiltedStylusIsCheckedAlongTheDescent) {
  // A stylus leaning 45° over +x (its head up and to +x of the ball) touches the top near its +x
  // edge. A 20 mm block floats at x 45–65, z 70–90: clear of the stylus at the start, but on the way
  // down from a clearance plane at z 100 the leaning shaft passes through it.
  machine_.tips.front().direction = Vec3(-1, 0, -1).normalized();  // from the head toward the ball
  geometry::TriangleMesh scene = cube_;
  const geometry::TriangleMesh block = geometry::make_cube(20, 2).mesh;
  const Eigen::Index v = scene.vertices.rows(), f = scene.faces.rows();
  scene.vertices.conservativeResize(v + block.vertices.rows(), 3);
  scene.faces.conservativeResize(f + block.faces.rows(), 3);
  scene.vertices.bottomRows(block.vertices.rows()) = block.vertices.rowwise() + Eigen::RowVector3d(45, 10, 70);
  scene.faces.bottomRows(block.faces.rows()) = block.faces.array() + static_cast<int>(v);
  const geometry::BallSweeper with_block(scene);
  const Touch near_edge = touch(Vec3(38, 20, 40), -Vec3::UnitZ());
  EXPECT_EQ(refusal(sweeper_, near_edge, 100), "(clear)");
  const std::string why = refusal(with_block, near_edge, 100);
  EXPECT_NE(why.find("stylus shaft would meet the part descending to the approach start"), std::string::npos) << why;
}

}  // namespace
}  // namespace cmm::planner
