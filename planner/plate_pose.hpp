// Where a plate stands: its pose from measured corners, by the rigid least-squares fit.
#pragma once

#include <span>

#include <Eigen/Geometry>

#include "hal/description/plate.hpp"

namespace cmm::planner {

// Plate pose T_X_P (P into frame X) from measured corners: ids (1-based) and their positions in X.
Eigen::Isometry3d fit_plate_pose(const description::Plate& plate, std::span<const int> ids,
                                 std::span<const Eigen::Vector3d> points_X);

}  // namespace cmm::planner
