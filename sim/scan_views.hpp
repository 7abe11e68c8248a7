// The laser scanner's views of a part: where each looks from and how far its own registration is off,
// so that a synthesized scan carries the misalignment between views a real multi-view merge has.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <utility>
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

// `count` views spread as default_views spreads them (count − 1 around at elevation_deg, one from above),
// each registered off by a pure translation of exactly offset_mm in a seeded random direction and no
// rotation: a merge whose views disagree by a known amount. Throws std::invalid_argument for count < 1,
// or an offset_mm or elevation_deg out of range, naming the option.
std::vector<ScanView> views_with_offset(int count, double offset_mm, std::uint64_t seed, double elevation_deg = 50);

// Two unit axes across a view's image (normal to its direction, right-handed with it), by a fixed rule:
// the first is the world axis least aligned with the direction (x before y before z on ties), made
// normal to it. A scanner's raster and a partial view's band are laid out along them.
std::pair<geometry::Vec3, geometry::Vec3> image_axes(const geometry::Vec3& direction);

// Throws std::invalid_argument, naming `option`, for an empty list or a direction that is not unit.
void check_views(const std::vector<ScanView>& views, const char* option);

}  // namespace cmm::sim
