// Rings at every profile point, zipped band by band; the poles are single vertices fanned to their
// neighbouring ring.
#include "geometry/revolved_mesher.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "geometry/mesh_builder.hpp"
#include "geometry/ring_zipper.hpp"

namespace cmm::geometry {
namespace {

std::vector<Vec3> ring(const Eigen::Vector2d& point, int n, bool twisted) {
  const double r = point.x(), z = point.y();
  if (r == 0.0) return {Vec3(0, 0, z)};
  // A half-step twist on every other ring zips equal-count neighbours into near-equilateral triangles.
  const double twist = twisted ? 0.5 : 0.0;
  std::vector<Vec3> points;
  for (int i = 0; i < n; ++i) {
    const double angle = 2 * std::numbers::pi * (i + twist) / n;
    points.emplace_back(r * std::cos(angle), r * std::sin(angle), z);
  }
  return points;
}

// Rings of `segments(r)` points, every other one twisted by half a step when `twist`.
template <class Segments>
TriangleMesh revolve(const std::vector<Eigen::Vector2d>& profile, Segments segments, bool twist) {
  if (profile.size() < 3 || profile.front().x() != 0.0 || profile.back().x() != 0.0)
    throw std::invalid_argument("mesh_revolved_profile: the profile must run from pole to pole");
  MeshBuilder mesh;
  std::vector<Vec3> below = ring(profile.front(), segments(profile.front().x()), false);
  for (std::size_t k = 1; k < profile.size(); ++k) {
    std::vector<Vec3> above = ring(profile[k], segments(profile[k].x()), twist && k % 2 == 1);
    const auto corner = [&](int c) {
      const auto n = static_cast<int>(below.size());
      return mesh.vertex(c < n ? below[c] : above[c - n]);
    };
    for (const auto& t : zip_rings(below, above)) mesh.triangle(corner(t[0]), corner(t[1]), corner(t[2]));
    below = std::move(above);
  }
  return mesh.finish();
}

}  // namespace

TriangleMesh mesh_revolved_profile(const std::vector<Eigen::Vector2d>& profile, double edge_length) {
  return revolve(profile, [&](double r) { return std::max(3, static_cast<int>(std::lround(2 * std::numbers::pi * r / edge_length))); }, true);
}

TriangleMesh mesh_revolved_profile_cad(const std::vector<Eigen::Vector2d>& profile, int segments) {
  if (segments < 3) throw std::invalid_argument("mesh_revolved_profile_cad: a ring needs at least 3 segments");
  return revolve(profile, [&](double) { return segments; }, false);
}

}  // namespace cmm::geometry
