// See true_edge_checks.hpp.
#include "true_edge_checks.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>

namespace cmm::planner::testing {

std::vector<Segment> sharp_segments(const geometry::TriangleMesh& mesh) {
  std::map<std::pair<int, int>, std::vector<int>> faces_of;
  for (int f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
      faces_of[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  auto normal = [&](int f) {
    const Vec3 a = geometry::vertex(mesh, mesh.faces(f, 0)), b = geometry::vertex(mesh, mesh.faces(f, 1)),
               c = geometry::vertex(mesh, mesh.faces(f, 2));
    return (b - a).cross(c - a).normalized().eval();
  };
  std::vector<Segment> segments;
  const double cos_20 = std::cos(20 * std::numbers::pi / 180);
  for (const auto& [edge, faces] : faces_of)
    if (faces.size() == 2 && normal(faces[0]).dot(normal(faces[1])) < cos_20)
      segments.push_back({geometry::vertex(mesh, edge.first), geometry::vertex(mesh, edge.second)});
  return segments;
}

std::vector<Vec3> corners_of(const std::vector<Segment>& segments) {
  std::map<std::array<double, 3>, int> degree;
  for (const auto& [a, b] : segments)
    for (const Vec3& v : {a, b}) ++degree[{v.x(), v.y(), v.z()}];
  std::vector<Vec3> corners;
  for (const auto& [v, count] : degree)
    if (count >= 3) corners.emplace_back(v[0], v[1], v[2]);
  return corners;
}

double distance_to(const std::vector<Segment>& segments, const Vec3& p) {
  double best = 1e300;
  for (const auto& [a, b] : segments) {
    const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + t * (b - a) - p).norm());
  }
  return best;
}

double angle_in_fan(const Vec3& d, const Vec3& axis, const Vec3& plane_normal) {
  const Vec3 in_plane = (d - d.dot(plane_normal) * plane_normal).normalized();
  return std::atan2(in_plane.cross(axis).norm(), in_plane.dot(axis));
}

}  // namespace cmm::planner::testing
