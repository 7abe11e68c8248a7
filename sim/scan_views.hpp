// The laser scanner's views of a part: where each looks from and how far its own registration is off,
// so that a synthesized scan carries the misalignment between views a real multi-view merge has.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "geometry/mesh.hpp"

namespace cmm::sim {

struct ScanView {
  // Unit, from the scanner toward the part. The scanner is far away: every beam of a view is parallel.
  geometry::Vec3 direction;
  // Maps where a point truly is (scene frame) to where this view reports it: the view's share of the
  // multi-view registration error, a small rigid motion about the scene origin (mm).
  Eigen::Isometry3d registration_error = Eigen::Isometry3d::Identity();
};

struct ViewSetOptions {
  int around = 6;                     // views spread evenly in azimuth, the first along +x
  double elevation_deg = 50;          // of the scanner above the horizon, for the views around
  bool from_above = true;             // one more view straight down
  double rotation_sigma_deg = 0.01;   // per axis, of each view's registration error
  double translation_sigma_mm = 0.01; // per axis, of each view's registration error
  std::uint64_t seed = 1;
};

// The default set: `around` views at the given elevation plus one from straight above, each with its
// own seeded registration error. Throws std::invalid_argument naming a bad option.
std::vector<ScanView> default_views(const ViewSetOptions& options = {});

// Throws std::invalid_argument, naming `option`, for an empty list or a direction that is not unit.
void check_views(const std::vector<ScanView>& views, const char* option);

}  // namespace cmm::sim
