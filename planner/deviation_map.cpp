// Software rasterizer of the deviation map: orthographic projection, z-buffer, flat Lambert shading
// on both sides of each triangle (a scan's mesh may be open or wound either way), then the discs.
#include "planner/deviation_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace cmm::planner {

namespace {

using geometry::Vec3;

// Screen x right, y down, depth growing toward the viewer.
struct View {
  Vec3 right, up, toward_viewer;
  double scale = 1;  // pixels per mm
  double offset_x = 0, offset_y = 0;

  Vec3 project(const Vec3& p) const {
    return {offset_x + scale * p.dot(right), offset_y - scale * p.dot(up), p.dot(toward_viewer)};
  }
};

View make_view(const geometry::TriangleMesh* mesh, const std::vector<MapPoint>& points, const DeviationMapOptions& o) {
  const double az = o.azimuth_deg * std::numbers::pi / 180, el = o.elevation_deg * std::numbers::pi / 180;
  View view;
  view.toward_viewer = Vec3(std::sin(az) * std::cos(el), -std::cos(az) * std::cos(el), std::sin(el));
  view.right = Vec3::UnitZ().cross(view.toward_viewer).normalized();
  view.up = view.toward_viewer.cross(view.right);

  double min_x = std::numeric_limits<double>::infinity(), max_x = -min_x, min_y = min_x, max_y = -min_x;
  auto extend = [&](const Vec3& p) {
    if (!p.allFinite()) return;
    const double x = p.dot(view.right), y = p.dot(view.up);
    min_x = std::min(min_x, x), max_x = std::max(max_x, x);
    min_y = std::min(min_y, y), max_y = std::max(max_y, y);
  };
  if (mesh) {
    for (Eigen::Index v = 0; v < mesh->vertices.rows(); ++v) extend(mesh->vertices.row(v).transpose());
  }
  for (const MapPoint& p : points) extend(p.position);
  if (!(min_x <= max_x)) min_x = max_x = min_y = max_y = 0;  // nothing to show: an empty picture

  const double margin = 0.06 * std::min(o.width, o.height);
  const double span_x = std::max(max_x - min_x, 1e-9), span_y = std::max(max_y - min_y, 1e-9);
  view.scale = std::min((o.width - 2 * margin) / span_x, (o.height - 2 * margin) / span_y);
  view.offset_x = o.width / 2.0 - view.scale * (min_x + max_x) / 2;
  view.offset_y = o.height / 2.0 + view.scale * (min_y + max_y) / 2;
  return view;
}

// The light comes from over the viewer's left shoulder, so the top, the front and the right side
// of a box each get their own shade.
std::uint8_t shade(const Vec3& a, const Vec3& b, const Vec3& c, const View& view) {
  const Vec3 normal = (b - a).cross(c - a);
  const double length = normal.norm();
  const Vec3 light = (view.toward_viewer + 0.8 * view.up - 0.5 * view.right).normalized();
  const double lambert = length > 0 ? std::abs(normal.dot(light)) / length : 0;
  return static_cast<std::uint8_t>(std::lround(255 * (0.28 + 0.6 * lambert)));
}

// A pixel index from a screen coordinate, clamped before the conversion (a far-off vertex must
// not overflow an int).
int pixel(double v, int last) { return static_cast<int>(std::clamp(v, -1.0, static_cast<double>(last) + 1)); }

void draw_triangle(const Vec3& a, const Vec3& b, const Vec3& c, std::uint8_t grey, RgbImage& image,
                   std::vector<double>& depth) {
  const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
  if (!std::isfinite(area) || !std::isfinite(a.z() + b.z() + c.z()) || std::abs(area) < 1e-12) return;
  const int x0 = std::max(0, pixel(std::floor(std::min({a.x(), b.x(), c.x()})), image.width - 1));
  const int x1 = std::min(image.width - 1, pixel(std::ceil(std::max({a.x(), b.x(), c.x()})), image.width - 1));
  const int y0 = std::max(0, pixel(std::floor(std::min({a.y(), b.y(), c.y()})), image.height - 1));
  const int y1 = std::min(image.height - 1, pixel(std::ceil(std::max({a.y(), b.y(), c.y()})), image.height - 1));
  auto edge = [](const Vec3& p, const Vec3& q, double x, double y) {
    return (q.x() - p.x()) * (y - p.y()) - (q.y() - p.y()) * (x - p.x());
  };
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5, py = y + 0.5;
      const double w0 = edge(b, c, px, py) / area, w1 = edge(c, a, px, py) / area, w2 = edge(a, b, px, py) / area;
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      const double z = w0 * a.z() + w1 * b.z() + w2 * c.z();
      double& stored = depth[static_cast<std::size_t>(y) * image.width + x];
      if (z <= stored) continue;
      stored = z;
      image.set(x, y, {grey, grey, grey});
    }
  }
}

void draw_disc(int cx, int cy, double radius, Rgb colour, RgbImage& image) {
  // A darker rim keeps a light disc readable on a light face.
  const Rgb rim{static_cast<std::uint8_t>(colour.r * 0.55), static_cast<std::uint8_t>(colour.g * 0.55),
                static_cast<std::uint8_t>(colour.b * 0.55)};
  const int reach = static_cast<int>(std::ceil(radius));
  for (int dy = -reach; dy <= reach; ++dy) {
    for (int dx = -reach; dx <= reach; ++dx) {
      const double d = std::hypot(dx, dy);
      if (d > radius) continue;
      image.set(cx + dx, cy + dy, d > radius - 1 && radius >= 3 ? rim : colour);
    }
  }
}

}  // namespace

DeviationMap render_deviation_map(const geometry::TriangleMesh* mesh, const std::vector<MapPoint>& points,
                                  const DeviationMapOptions& options) {
  DeviationMap map;
  map.image = RgbImage(options.width, options.height, options.background);
  const View view = make_view(mesh, points, options);
  std::vector<double> depth(static_cast<std::size_t>(options.width) * options.height,
                            -std::numeric_limits<double>::infinity());

  double extent_mm = 0;  // of the drawn mesh, for the depth tolerance of the points
  if (mesh && mesh->vertices.rows() > 0) {
    extent_mm = (mesh->vertices.colwise().maxCoeff() - mesh->vertices.colwise().minCoeff()).norm();
    if (!std::isfinite(extent_mm)) extent_mm = 0;
    const int vertices = static_cast<int>(mesh->vertices.rows());
    for (Eigen::Index f = 0; f < mesh->faces.rows(); ++f) {
      if ((mesh->faces.row(f).array() < 0).any() || (mesh->faces.row(f).array() >= vertices).any()) continue;
      const Vec3 a = geometry::vertex(*mesh, mesh->faces(f, 0)), b = geometry::vertex(*mesh, mesh->faces(f, 1)),
                 c = geometry::vertex(*mesh, mesh->faces(f, 2));
      draw_triangle(view.project(a), view.project(b), view.project(c), shade(a, b, c, view), map.image, depth);
    }
  }

  // A point on the surface is at the surface's depth up to the mesh's facets and the pixel's size:
  // it counts as hidden only when something lies clearly nearer to the viewer at every pixel
  // around its centre (an edge point sits where two faces, or a face and the background, meet).
  const double tolerance = 0.005 * extent_mm + 1.5 / view.scale;
  map.points.reserve(points.size());
  for (const MapPoint& p : points) {
    const Vec3 s = view.project(p.position);
    DrawnPoint drawn;
    if (s.allFinite()) {
      drawn.x = pixel(std::floor(s.x()), options.width - 1);
      drawn.y = pixel(std::floor(s.y()), options.height - 1);
    }
    if (drawn.x >= 0 && drawn.y >= 0 && drawn.x < options.width && drawn.y < options.height) {
      double farthest = std::numeric_limits<double>::infinity();
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = std::clamp(drawn.x + dx, 0, options.width - 1), y = std::clamp(drawn.y + dy, 0, options.height - 1);
          farthest = std::min(farthest, depth[static_cast<std::size_t>(y) * options.width + x]);
        }
      }
      drawn.visible = s.z() >= farthest - tolerance;
    }
    if (drawn.visible) {
      draw_disc(drawn.x, drawn.y, p.radius_px, p.colour, map.image);
      ++map.visible;
    }
    map.points.push_back(drawn);
  }
  return map;
}

}  // namespace cmm::planner
