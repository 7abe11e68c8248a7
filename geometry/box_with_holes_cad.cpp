// The six faces of the box, each a rectangle (the top and bottom with the hole circles and slots cut
// out) ear-clipped in its own plane coordinates, and the bore walls as strips. Seam points come from the
// same arrays on both faces, so MeshBuilder welds them exactly.
#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <stdexcept>

#include "geometry/box_with_holes_mesher.hpp"
#include "geometry/box_with_holes_slot.hpp"
#include "geometry/mesh_builder.hpp"
#include "geometry/polygon_triangulation.hpp"

namespace cmm::geometry {
namespace {

using Point2 = Eigen::Vector2d;

// 0 and length, and with a spacing the points about that far apart between them.
std::vector<double> edge_stations(double length, double spacing) {
  const int n = spacing > 0 ? std::max(1, static_cast<int>(std::lround(length / spacing))) : 1;
  std::vector<double> s(n + 1);
  for (int i = 0; i < n; ++i) s[i] = length * i / n;
  s.back() = length;
  return s;
}

// The rectangle [0, a.back()] × [0, b.back()] counter-clockwise through every station.
Polygon2d rectangle(const std::vector<double>& a, const std::vector<double>& b) {
  Polygon2d outline;
  for (std::size_t i = 0; i + 1 < a.size(); ++i) outline.emplace_back(a[i], 0.0);
  for (std::size_t j = 0; j + 1 < b.size(); ++j) outline.emplace_back(a.back(), b[j]);
  for (std::size_t i = a.size() - 1; i > 0; --i) outline.emplace_back(a[i], b.back());
  for (std::size_t j = b.size() - 1; j > 0; --j) outline.emplace_back(0.0, b[j]);
  return outline;
}

// One plane face: `lift` maps plane coordinates to space; `flip` when lift's orientation is inward.
void add_face(MeshBuilder& mesh, const Polygon2d& outline, const std::vector<Polygon2d>& holes,
              const std::function<Vec3(const Point2&)>& lift, bool flip) {
  std::vector<int> index;
  for (const Point2& p : outline) index.push_back(mesh.vertex(lift(p)));
  for (const Polygon2d& hole : holes)
    for (const Point2& p : hole) index.push_back(mesh.vertex(lift(p)));
  for (const auto& t : triangulate_polygon(outline, holes)) {
    if (flip) mesh.triangle(index[t[0]], index[t[2]], index[t[1]]);
    else mesh.triangle(index[t[0]], index[t[1]], index[t[2]]);
  }
}

}  // namespace

TriangleMesh mesh_box_with_holes_cad(const Vec3& size, const std::vector<VerticalHole>& holes,
                                     const std::vector<int>& segments, double boundary_spacing) {
  if (segments.size() != holes.size()) throw std::invalid_argument("mesh_box_with_holes_cad: one segment count per hole");
  const std::vector<double> xs = edge_stations(size.x(), boundary_spacing), ys = edge_stations(size.y(), boundary_spacing),
                            zs = edge_stations(size.z(), boundary_spacing);
  std::vector<Polygon2d> circles;  // counter-clockwise seen from +z
  for (std::size_t h = 0; h < holes.size(); ++h) {
    if (segments[h] < 3) throw std::invalid_argument("mesh_box_with_holes_cad: a hole needs at least 3 segments");
    if (!(holes[h].slot_length >= 0) || !std::isfinite(holes[h].slot_length))
      throw std::invalid_argument("mesh_box_with_holes_cad: a slot_length is negative or not finite");
    Polygon2d circle;
    if (holes[h].slot_length > 0) {
      // Each half circle as its own fan of chords; each straight side runs from one's end to the other's start.
      const SlotRim rim(holes[h]);
      const int half_segments = std::max(1, (segments[h] + 1) / 2);
      const double half_circle = std::numbers::pi * holes[h].radius;
      for (const double start : {0.0, half_circle + holes[h].slot_length})
        for (int k = 0; k <= half_segments; ++k) circle.push_back(rim.point(start + half_circle * k / half_segments));
    } else {
      for (int k = 0; k < segments[h]; ++k) {
        const double angle = 2 * std::numbers::pi * k / segments[h];
        circle.emplace_back(holes[h].x + holes[h].radius * std::cos(angle), holes[h].y + holes[h].radius * std::sin(angle));
      }
    }
    circles.push_back(std::move(circle));
  }
  std::vector<Polygon2d> cut_outs;  // as holes of a face: clockwise
  for (const Polygon2d& c : circles) cut_outs.emplace_back(c.rbegin(), c.rend());

  MeshBuilder mesh;
  const double X = size.x(), Y = size.y(), Z = size.z();
  add_face(mesh, rectangle(xs, ys), cut_outs, [&](const Point2& p) { return Vec3(p.x(), p.y(), Z); }, false);
  add_face(mesh, rectangle(xs, ys), cut_outs, [&](const Point2& p) { return Vec3(p.x(), p.y(), 0.0); }, true);
  add_face(mesh, rectangle(xs, zs), {}, [&](const Point2& p) { return Vec3(p.x(), 0.0, p.y()); }, false);
  add_face(mesh, rectangle(xs, zs), {}, [&](const Point2& p) { return Vec3(p.x(), Y, p.y()); }, true);
  add_face(mesh, rectangle(ys, zs), {}, [&](const Point2& p) { return Vec3(0.0, p.x(), p.y()); }, true);
  add_face(mesh, rectangle(ys, zs), {}, [&](const Point2& p) { return Vec3(X, p.x(), p.y()); }, false);
  for (const Polygon2d& circle : circles)  // the wall faces the axis
    for (std::size_t k = 0; k < circle.size(); ++k) {
      const Point2 &a = circle[k], &b = circle[(k + 1) % circle.size()];
      mesh.quad(Vec3(a.x(), a.y(), 0.0), Vec3(a.x(), a.y(), Z), Vec3(b.x(), b.y(), Z), Vec3(b.x(), b.y(), 0.0), true);
    }
  return mesh.finish();
}

}  // namespace cmm::geometry
