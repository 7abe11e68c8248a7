// A bore measured by touches on its wall at one depth: circle fit to the trigger centres in the
// plane across the hole axis → centre, diameter, roundness and their uncertainty from trigger noise.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "planner/edge_compensation.hpp"

namespace cmm::planner {

struct BoreInput {
  int hole_id = -1;                 // plan hole id, named in errors
  std::vector<Vec3> centres;        // trigger centres on the wall, M; the probe inside the hole, approaching
                                    // from the axis toward the wall; at least three, usually six
  Vec3 axis = Vec3::Zero();         // unit hole axis (its sign is kept in the output)
  double ball_radius_mm = 0;
  double trigger_sigma_mm = 0.001;  // 1-σ of each trigger centre, per axis (isotropic)
};

struct BoreMeasurement {
  int hole_id = -1;
  PointFrame frame = PointFrame::machine;
  Vec3 centre = Vec3::Zero();     // on the measured axis, at the touches' mean depth
  Vec3 axis = Vec3::UnitZ();      // the given axis (not measured: one depth fixes no direction)
  double diameter_mm = 0;         // 2 (centre-circle radius + r)
  double roundness_mm = 0;        // peak-to-valley of the radial residuals
  double rms_mm = 0;              // of the radial residuals
  double depth_spread_mm = 0;     // max − min of the touches along the axis: they should share one depth
  // From the trigger noise alone (σ on every centre), first order about the fit.
  Eigen::Matrix3d centre_covariance = Eigen::Matrix3d::Zero();  // mm², in the plane across the axis
  double centre_sigma_mm = 0;     // √(largest eigenvalue of centre_covariance)
  double diameter_sigma_mm = 0;
  std::vector<double> residuals_mm;  // per touch: distance from the centre minus the fitted radius
};

// Projects the centres along the axis into one plane, fits a circle (Kåsa's algebraic fit seeds a
// Gauss–Newton geometric one) and adds r. Throws CompensationError naming the hole for fewer than
// three touches, non-finite input, touches on one line, or a fit that does not converge.
BoreMeasurement measure_bore(const BoreInput& input);

// The wall points the touches measured: each centre moved by r away from the fitted axis, with
// σ along that direction; for the merged cloud.
std::vector<MeasuredPoint> bore_wall_points(const BoreInput& input, const BoreMeasurement& bore);

// Maps a bore measured in M into S (centre by T_M_S⁻¹, axis and covariance by its rotation).
// Throws CompensationError when it is already in S.
BoreMeasurement to_scan_frame(const BoreMeasurement& bore, const Eigen::Isometry3d& T_M_S);

}  // namespace cmm::planner
