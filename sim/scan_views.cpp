// Views on a cone of constant elevation, so that vertical walls on every side turn toward some view;
// registration errors drawn per view in view order, so that adding a view leaves the others' unchanged.
#include "sim/scan_views.hpp"

#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

namespace cmm::sim {

namespace {

constexpr double kDegree = std::numbers::pi / 180;

Eigen::Isometry3d draw_error(std::mt19937_64& engine, double rotation_sigma_rad, double translation_sigma_mm) {
  // A zero σ draws nothing: std::normal_distribution wants a positive one.
  auto draw = [&](double sigma) {
    return sigma > 0 ? geometry::Vec3(std::normal_distribution<double>(0, sigma)(engine),
                                      std::normal_distribution<double>(0, sigma)(engine),
                                      std::normal_distribution<double>(0, sigma)(engine))
                     : geometry::Vec3::Zero();
  };
  const geometry::Vec3 rotation = draw(rotation_sigma_rad), translation = draw(translation_sigma_mm);
  Eigen::Isometry3d error = Eigen::Isometry3d::Identity();
  if (rotation.norm() > 0) error.linear() = Eigen::AngleAxisd(rotation.norm(), rotation.normalized()).toRotationMatrix();
  error.translation() = translation;
  return error;
}

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

}  // namespace

std::vector<ScanView> default_views(const ViewSetOptions& o) {
  require(o.around >= 0, "views: around must be >= 0");
  require(o.around > 0 || o.from_above, "views: around = 0 and no view from above leaves no view");
  require(o.elevation_deg > 0 && o.elevation_deg <= 90, "views: elevation_deg must be in (0, 90]");
  require(o.rotation_sigma_deg >= 0 && std::isfinite(o.rotation_sigma_deg),
          "views: rotation_sigma_deg must be finite and >= 0");
  require(o.translation_sigma_mm >= 0 && std::isfinite(o.translation_sigma_mm),
          "views: translation_sigma_mm must be finite and >= 0");
  std::mt19937_64 engine(o.seed);
  std::vector<ScanView> views;
  const double elevation = o.elevation_deg * kDegree;
  for (int k = 0; k < o.around; ++k) {
    const double azimuth = 2 * std::numbers::pi * k / o.around;
    // The scanner stands at (cos az, sin az) out and up by the elevation, and looks back and down.
    const geometry::Vec3 toward_scanner(std::cos(elevation) * std::cos(azimuth),
                                        std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    views.push_back({-toward_scanner, draw_error(engine, o.rotation_sigma_deg * kDegree, o.translation_sigma_mm)});
  }
  if (o.from_above)
    views.push_back({geometry::Vec3(0, 0, -1), draw_error(engine, o.rotation_sigma_deg * kDegree, o.translation_sigma_mm)});
  return views;
}

std::vector<ScanView> views_with_offset(int count, double offset_mm, std::uint64_t seed, double elevation_deg) {
  require(count >= 1, "views: count must be >= 1");
  require(offset_mm >= 0 && std::isfinite(offset_mm), "views: offset_mm must be finite and >= 0");
  std::vector<ScanView> views = default_views({.around = count - 1,
                                               .elevation_deg = elevation_deg,
                                               .from_above = true,
                                               .rotation_sigma_deg = 0,
                                               .translation_sigma_mm = 0,
                                               .seed = seed});
  // A direction uniform on the sphere: three Gaussians, normalised (a zero draw, never seen, is redrawn).
  std::mt19937_64 engine(seed);
  std::normal_distribution<double> gauss(0, 1);
  for (ScanView& view : views) {
    geometry::Vec3 direction = geometry::Vec3::Zero();
    while (direction.norm() < 1e-12)
      for (int k = 0; k < 3; ++k) direction[k] = gauss(engine);
    view.registration_error.translation() = offset_mm * direction.normalized();
  }
  return views;
}

std::pair<geometry::Vec3, geometry::Vec3> image_axes(const geometry::Vec3& direction) {
  int least = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(direction[k]) < std::abs(direction[least])) least = k;
  const geometry::Vec3 axis = geometry::Vec3::Unit(least);
  const geometry::Vec3 first = (axis - axis.dot(direction) * direction).normalized();
  return {first, direction.cross(first)};
}

void check_views(const std::vector<ScanView>& views, const char* option) {
  require(!views.empty(), std::string(option) + ": no views");
  for (const ScanView& view : views) {
    require(view.direction.allFinite() && std::abs(view.direction.norm() - 1) < 1e-9,
            std::string(option) + ": a view direction is not a unit vector");
    require(view.registration_error.matrix().allFinite(),
            std::string(option) + ": a view's registration error is not finite");
  }
}

}  // namespace cmm::sim
