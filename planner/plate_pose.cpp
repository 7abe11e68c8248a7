// The plate's pose: nominal corners onto measured ones.
#include "planner/plate_pose.hpp"

#include <vector>

#include "planner/rigid_fit.hpp"

namespace cmm::planner {

Eigen::Isometry3d fit_plate_pose(const description::Plate& plate, std::span<const int> ids,
                                 std::span<const Eigen::Vector3d> points_X) {
  std::vector<Eigen::Vector3d> nominal;
  for (int id : ids) nominal.push_back(plate.corner(id));
  return fit_rigid(nominal, points_X).transform;
}

}  // namespace cmm::planner
