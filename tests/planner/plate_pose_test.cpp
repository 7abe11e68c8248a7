// The plate's pose from measured corners: any three corners of a moved plate give the motion back.
#include <gtest/gtest.h>

#include <vector>

#include "planner/plate_pose.hpp"

namespace cmm::planner {
namespace {

TEST(PlatePose, FromMeasuredCorners) {
  const description::Plate plate = description::default_plate();
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.1, -0.2, 1).normalized()).toRotationMatrix();
  truth.translation() = Eigen::Vector3d(310, -45, 120);
  const std::vector<int> ids{4, 1, 2};
  std::vector<Eigen::Vector3d> measured;
  for (int id : ids) measured.push_back(truth * plate.corner(id));
  const Eigen::Isometry3d pose = fit_plate_pose(plate, ids, measured);
  EXPECT_NEAR((pose.matrix() - truth.matrix()).norm(), 0, 1e-9);
}

}  // namespace
}  // namespace cmm::planner
