// The loop gives a first axis (the direction it spreads least along) and circle; the wall grown from the
// facets beside it gives the fitted ones, as a bore's wall does for a rim (bore_detection.cpp).
#include "geometry/wall_hole.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_set>

#include "geometry/circle_fit.hpp"

namespace cmm::geometry {
namespace {

constexpr double kUprightCos = 0.26;  // within 15° of the axis
constexpr std::size_t kMinWallVertices = 8;
constexpr std::size_t kDirections = 36;    // 10° sectors round the axis
constexpr double kMinDirectionShare = 0.9;  // the loop passes through this share of them
constexpr double kMinWallShare = 0.2;   // of the facets beside the loop, at least this much wall,
constexpr double kMinKnownShare = 0.8;  // and this much wall or the face the hole opens in

// Points moved along `axis` into the plane through their mean: a cylinder's points become a circle.
std::vector<Vec3> across(const std::vector<Vec3>& points, const Vec3& axis) {
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : points) mean += p / static_cast<double>(points.size());
  std::vector<Vec3> out;
  for (const Vec3& p : points) out.push_back(p - (p - mean).dot(axis) * axis);
  return out;
}

// A facet of the wall: its normal across the axis, facing it.
bool faces_axis(const TriangleMesh& mesh, const FaceGeometry& faces, int f, const Vec3& axis, const Vec3& centre, double radius) {
  const Vec3 n = faces.normals.row(f).transpose();
  if (std::abs(n.dot(axis)) > 0.5) return false;
  Vec3 to_axis = centre - face_centroid(mesh, f);
  to_axis -= to_axis.dot(axis) * axis;
  const double distance = to_axis.norm();
  return distance > 0.5 * radius && distance < 1.5 * radius && n.dot(to_axis) > 0.5 * distance;
}

}  // namespace

std::vector<int> wall_middle(const TriangleMesh& mesh, const std::vector<int>& wall, const Vec3& axis, double margin) {
  double low = INFINITY, high = -INFINITY;
  for (int f : wall) {
    const double h = face_centroid(mesh, f).dot(axis);
    low = std::min(low, h), high = std::max(high, h);
  }
  std::vector<int> middle;
  for (int f : wall) {
    const double h = face_centroid(mesh, f).dot(axis);
    if (h > low + margin && h < high - margin) middle.push_back(f);
  }
  return middle;
}

std::optional<Circle3> wall_circle(const TriangleMesh& mesh, const FaceGeometry& faces, const std::vector<int>& wall, const Vec3& axis) {
  std::vector<Vec3> upright;
  std::unordered_set<int> taken;
  for (int f : wall) {
    if (std::abs(faces.normals.row(f).dot(axis.transpose())) > kUprightCos) continue;
    for (int k = 0; k < 3; ++k)
      if (taken.insert(mesh.faces(f, k)).second) upright.push_back(vertex(mesh, mesh.faces(f, k)));
  }
  if (upright.size() < kMinWallVertices) return std::nullopt;
  Circle3 circle = fit_circle(across(upright, axis));
  if (!(circle.radius > 0)) return std::nullopt;
  // Once more without the vertices a stray fold put far off it.
  std::vector<Vec3> kept;
  for (const Vec3& p : upright) {
    Vec3 off = p - circle.centre;
    off -= off.dot(axis) * axis;
    if (std::abs(off.norm() - circle.radius) <= 3 * circle.rms_mm) kept.push_back(p);
  }
  if (kept.size() >= kMinWallVertices && kept.size() < upright.size()) circle = fit_circle(across(kept, axis));
  if (!(circle.radius > 0)) return std::nullopt;
  circle.normal = axis;
  return circle;
}

namespace {

// The hole round `first_axis`, if the loop runs once round it along a wall facing it.
std::optional<WallHole> round_axis(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                                   const BoundaryLoop& loop, const std::vector<Vec3>& points, const Vec3& first_axis,
                                   double circle_tolerance) {
  const std::size_t n = points.size();
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : points) mean += p / static_cast<double>(n);
  const Circle3 first = fit_circle(across(points, first_axis));
  if (!(first.radius > 0)) return std::nullopt;

  // Round the axis: the loop passes nearly every direction from it. Not its winding number: where the
  // views saw the wall in patches, the loop runs along the rim one way and below a patch the other.
  const Vec3 u = first_axis.unitOrthogonal(), v = first_axis.cross(u);
  std::vector<bool> passed(kDirections, false);
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 4; ++k) {  // along each side, so a long side passes the directions it spans
      const Vec3 d = points[i] + (points[(i + 1) % n] - points[i]) * (k / 4.0) - first.centre;
      const double angle = std::atan2(d.dot(v), d.dot(u)) + std::numbers::pi;
      passed[std::min(kDirections - 1, static_cast<std::size_t>(angle / (2 * std::numbers::pi) * kDirections))] = true;
    }
  if (static_cast<double>(std::count(passed.begin(), passed.end(), true)) < kMinDirectionShare * kDirections) return std::nullopt;

  // The facets beside the loop: wall, or the face the hole opens in where a view missed the wall up to
  // the rim (the loop runs along the rim there); some wall, nothing else.
  std::vector<int> wall;
  std::unordered_set<int> in_wall, beside;
  std::size_t entry_face = 0;
  Vec3 entry_normal = Vec3::Zero();
  for (int h : loop.half_edges) {
    const int f = EdgeAdjacency::face_of(h);
    if (!beside.insert(f).second) continue;
    if (faces_axis(mesh, faces, f, first_axis, first.centre, first.radius)) {
      in_wall.insert(f);
      wall.push_back(f);
    } else if (std::abs(faces.normals.row(f).dot(first_axis.transpose())) > 0.7) {
      Vec3 off = face_centroid(mesh, f) - first.centre;
      off -= off.dot(first_axis) * first_axis;
      if (off.norm() > 0.8 * first.radius) ++entry_face, entry_normal += faces.normals.row(f).transpose();
    }
  }
  const auto share = [&](std::size_t count) { return static_cast<double>(count) / static_cast<double>(beside.size()); };
  if (share(wall.size()) < kMinWallShare || share(wall.size() + entry_face) < kMinKnownShare) return std::nullopt;
  for (std::size_t next = 0; next < wall.size(); ++next)
    for (int k = 0; k < 3; ++k) {
      const int g = adjacency.other_face(adjacency.face_edges(wall[next], k), wall[next]);
      if (g >= 0 && !in_wall.contains(g) && faces_axis(mesh, faces, g, first_axis, first.centre, first.radius)) {
        in_wall.insert(g);
        wall.push_back(g);
      }
    }

  // The axis the wall's normals are all across; pointing from the loop up the wall, toward the entry.
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  std::vector<int> wall_vertices;
  std::unordered_set<int> seen;
  Vec3 wall_centre = Vec3::Zero();
  double wall_area = 0;
  for (int f : wall) {
    const Vec3 normal = faces.normals.row(f).transpose();
    scatter += faces.areas[static_cast<std::size_t>(f)] * normal * normal.transpose();
    wall_centre += faces.areas[static_cast<std::size_t>(f)] * face_centroid(mesh, f);
    wall_area += faces.areas[static_cast<std::size_t>(f)];
    for (int k = 0; k < 3; ++k)
      if (seen.insert(mesh.faces(f, k)).second) wall_vertices.push_back(mesh.faces(f, k));
  }
  if (!(wall_area > 0) || wall_vertices.size() < 8) return std::nullopt;
  wall_centre /= wall_area;
  Vec3 axis = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(0);
  // The loop's own axis is only a start: a wall seen to a depth that varies as sin θ round it leaves a
  // planar loop tilted by atan(amplitude / radius), and the wall's normals know better. Beyond 45° they
  // are no wall round that loop.
  if (std::abs(axis.dot(first_axis)) < std::cos(std::numbers::pi / 4)) return std::nullopt;
  // Out of the material at the entry: along the entry face's normal where the loop runs beside it,
  // else from the loop (the deepest seen) up the wall.
  if (entry_face >= 3 ? axis.dot(entry_normal) < 0 : axis.dot(wall_centre - mean) < 0) axis = -axis;

  std::vector<Vec3> on_wall;
  for (int v : wall_vertices) on_wall.push_back(vertex(mesh, v));
  const std::optional<Circle3> fitted = wall_circle(mesh, faces, wall_middle(mesh, wall, axis, kRimZoneMm), axis);
  if (!fitted) return std::nullopt;
  const Circle3& circle = *fitted;
  if (circle.rms_mm > circle_tolerance * circle.radius ||
      std::abs(circle.radius - first.radius) > 0.2 * first.radius)
    return std::nullopt;

  // The entry: where the wall ends up the axis (its 98th percentile, past the few raw vertices that the
  // rounded crease leaves); the seen depth down to the loop's deepest point.
  std::vector<double> height;
  for (const Vec3& p : on_wall) height.push_back((p - circle.centre).dot(axis));
  std::sort(height.begin(), height.end());
  const double top = height[static_cast<std::size_t>(0.98 * static_cast<double>(height.size() - 1))];
  double bottom = top;
  for (const Vec3& p : points) bottom = std::min(bottom, (p - circle.centre).dot(axis));

  WallHole hole;
  hole.axis = axis;
  hole.entry_centre = circle.centre + top * axis;
  hole.radius = circle.radius;
  hole.roundness_mm = circle.roundness_mm;
  hole.rms_mm = circle.rms_mm;
  hole.seen_depth_mm = top - bottom;
  hole.wall_faces = std::move(wall);
  return hole;
}

// The normals most of the facets beside the loop share, the largest group first: one of them is the face
// the hole opens in, where the loop runs along the rim on one side and deep down a wall seen on the other
// (the wall's normals fan out round the axis, the face's agree). A wall seen deeper than the hole is wide
// hides the axis from the loop's spread and from the normals' scatter alike; and where the loop runs along
// the rim for a third of the way round, a stretch of wall 15° round may have as many facets beside it as
// the face (the plate's Ø8 bore in the merged partial views: 10 against 11), so the three largest groups.
std::vector<Vec3> entry_normals(const FaceGeometry& faces, const BoundaryLoop& loop) {
  std::vector<Vec3> normals;
  for (int h : loop.half_edges) normals.push_back(faces.normals.row(EdgeAdjacency::face_of(h)).transpose());
  const double close = std::cos(15 * std::numbers::pi / 180);
  const std::size_t stride = std::max<std::size_t>(1, normals.size() / 256);  // a long outer loop stays linear
  std::vector<Vec3> groups;
  std::vector<bool> taken(normals.size(), false);
  while (groups.size() < 3) {
    std::size_t best = 0, best_count = 0;
    for (std::size_t i = 0; i < normals.size(); i += stride) {
      if (taken[i]) continue;
      std::size_t count = 0;
      for (std::size_t j = 0; j < normals.size(); ++j) count += !taken[j] && normals[j].dot(normals[i]) > close;
      if (count > best_count) best = i, best_count = count;
    }
    if (best_count == 0) break;
    Vec3 mean = Vec3::Zero();
    const Vec3 seed = normals[best];
    for (std::size_t j = 0; j < normals.size(); ++j)
      if (!taken[j] && normals[j].dot(seed) > close) mean += normals[j], taken[j] = true;
    if (mean.norm() > 0) groups.push_back(mean.normalized());
  }
  return groups;
}

}  // namespace

std::optional<WallHole> wall_hole(const TriangleMesh& mesh, const EdgeAdjacency& adjacency, const FaceGeometry& faces,
                                  const BoundaryLoop& loop, double circle_tolerance) {
  const std::size_t n = loop.vertices.size();
  if (n < 8 || loop.half_edges.size() != n) return std::nullopt;
  std::vector<Vec3> points;
  for (int v : loop.vertices) points.push_back(vertex(mesh, v));
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : points) mean += p / static_cast<double>(n);
  // Where to start looking for the axis: the direction the loop spreads least along (it runs round the
  // axis), or, where it also climbs the wall further than the hole is wide, the one the facets beside
  // it are square to, or (most of them in the face round the hole) along.
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero(), normals = Eigen::Matrix3d::Zero();
  for (const Vec3& p : points) spread += (p - mean) * (p - mean).transpose();
  for (int h : loop.half_edges) {
    const Vec3 normal = faces.normals.row(EdgeAdjacency::face_of(h)).transpose();
    normals += normal * normal.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> by_spread(spread), by_normals(normals);
  std::vector<Vec3> starts{by_spread.eigenvectors().col(0), by_normals.eigenvectors().col(0), by_normals.eigenvectors().col(2)};
  for (const Vec3& normal : entry_normals(faces, loop)) starts.push_back(normal);
  for (const Vec3& first_axis : starts)
    if (auto hole = round_axis(mesh, adjacency, faces, loop, points, first_axis, circle_tolerance)) return hole;
  return std::nullopt;
}

}  // namespace cmm::geometry
