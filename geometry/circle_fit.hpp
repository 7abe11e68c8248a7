// Best-fit circle in 3-D: plane by PCA, then a geometric least-squares circle in that plane.
// Hole rims and bores are reported through it (centre, radius, axis, roundness).
#pragma once

#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

struct Circle3 {
  Vec3 centre = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();  // unit; its sign is the caller's to choose
  double radius = 0;
  double rms_mm = 0;            // RMS of radial residuals
  double roundness_mm = 0;      // max − min radial distance (peak to valley)
  double out_of_plane_mm = 0;   // RMS distance from the plane
};

// Needs at least three points that are not collinear; otherwise radius is 0.
Circle3 fit_circle(const std::vector<Vec3>& points);

}  // namespace cmm::geometry
