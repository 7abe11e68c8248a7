// Plate solids: a convex prism with one corner cut, or a rectangle with a through hole.
#include "sim/plate_mesh.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

#include "geometry/box_with_holes_mesher.hpp"

namespace cmm::sim {

using geometry::Vec3;

namespace {
// The top outline, counter-clockwise from +z, with the chamfered corner split in two.
std::vector<Vec3> outline(const description::Plate& plate) {
  std::vector<Vec3> out;
  for (int id = 1; id <= plate.corner_count(); ++id) {
    const Vec3& c = plate.corner(id);
    if (plate.fiducial.kind == description::PlateFiducial::Kind::chamfer && id == plate.fiducial.corner) {
      const double s = plate.fiducial.size_mm;
      out.push_back(c + s * (plate.corner(plate.previous(id)) - c).normalized());
      out.push_back(c + s * (plate.corner(plate.next(id)) - c).normalized());
    } else {
      out.push_back(c);
    }
  }
  return out;
}

geometry::TriangleMesh prism(const std::vector<Vec3>& top, double thickness) {
  const int n = static_cast<int>(top.size());
  geometry::TriangleMesh mesh;
  mesh.vertices.resize(2 * n, 3);
  for (int i = 0; i < n; ++i) {
    mesh.vertices.row(i) = top[static_cast<std::size_t>(i)].transpose();
    mesh.vertices.row(n + i) = (top[static_cast<std::size_t>(i)] - Vec3(0, 0, thickness)).transpose();
  }
  mesh.faces.resize(2 * (n - 2) + 2 * n, 3);
  int f = 0;
  for (int i = 1; i + 1 < n; ++i) {
    mesh.faces.row(f++) << 0, i, i + 1;               // top, seen from +z counter-clockwise
    mesh.faces.row(f++) << n, n + i + 1, n + i;       // bottom, reversed
  }
  for (int i = 0; i < n; ++i) {
    int j = (i + 1) % n;
    mesh.faces.row(f++) << i, n + i, n + j;
    mesh.faces.row(f++) << i, n + j, j;
  }
  return mesh;
}
}  // namespace

geometry::TriangleMesh plate_mesh(const description::Plate& plate) {
  if (plate.fiducial.kind == description::PlateFiducial::Kind::chamfer) return prism(outline(plate), plate.thickness_mm);

  const auto& c = plate.corners;
  const bool rectangle = c.size() == 4 && c[0].y() == c[1].y() && c[1].x() == c[2].x() && c[2].y() == c[3].y() &&
                         c[3].x() == c[0].x() && c[0].x() < c[1].x() && c[1].y() < c[2].y();
  if (!rectangle)
    throw std::invalid_argument("plate \"" + plate.name +
                                "\": a hole fiducial is simulated on an axis-aligned rectangle only");
  if (plate.fiducial.depth_mm > 0 && std::abs(plate.fiducial.depth_mm - plate.thickness_mm) > 1e-9)
    throw std::invalid_argument("plate \"" + plate.name + "\": a blind fiducial hole is not simulated");
  const Vec3 size(c[1].x() - c[0].x(), c[2].y() - c[1].y(), plate.thickness_mm);
  const geometry::VerticalHole hole{plate.fiducial.centre.x() - c[0].x(), plate.fiducial.centre.y() - c[0].y(),
                                    plate.fiducial.diameter_mm / 2};
  geometry::TriangleMesh mesh = geometry::mesh_box_with_holes(size, {hole}, std::min(2.0, hole.radius / 2));
  for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v)
    mesh.vertices.row(v) += Vec3(c[0].x(), c[0].y(), plate.top_z() - plate.thickness_mm).transpose();
  return mesh;
}

}  // namespace cmm::sim
