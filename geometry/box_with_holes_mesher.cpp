// The top and bottom faces are one 2-D pattern placed at z = 0 and z = size.z: a uniform grid in which
// an octagon of cells around each hole (or slot) gives way to rings zipped between the rim and the octagon;
// the walls are lifted from the pattern's boundary polygons. Every seam point comes from the same
// arrays on both sides, so MeshBuilder welds it exactly.
#include "geometry/box_with_holes_mesher.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "geometry/box_with_holes_slot.hpp"
#include "geometry/mesh_builder.hpp"
#include "geometry/ring_zipper.hpp"

namespace cmm::geometry {
namespace {

using Point2 = Eigen::Vector2d;
using Node = Eigen::Vector2i;  // grid node indices (i, j)
using Polygon2 = std::vector<Point2>;
using Triangle2 = std::array<Point2, 3>;  // counter-clockwise seen from +z

// About length / h equal intervals; the last line is exactly `length`, so it lies on the true edge.
std::vector<double> grid_lines(double length, double h) {
  const int n = std::max(1, static_cast<int>(std::lround(length / h)));
  std::vector<double> lines(n + 1);
  for (int i = 0; i < n; ++i) lines[i] = length * i / n;
  lines.back() = length;
  return lines;
}

struct Grid {
  std::vector<double> x, y, z;

  int cells_x() const { return static_cast<int>(x.size()) - 1; }
  int cells_y() const { return static_cast<int>(y.size()) - 1; }
  Point2 node(const Node& n) const { return {x[n.x()], y[n.y()]}; }
};

// The block of grid around one hole, in node indices: the octagon i0 ≤ i ≤ i1, j0 ≤ j ≤ j1,
// s0 ≤ i + j ≤ s1, d0 ≤ i − j ≤ d1. Its sides run along grid lines and node diagonals, so it is a
// union of whole and half cells, stays close to a circle (spokes from the rim of nearly equal length)
// and meets no ray from the axis at a grazing angle.
struct Octagon {
  int i0, i1, j0, j1, s0, s1, d0, d1;

  bool contains(int i, int j) const {
    return i >= i0 && i <= i1 && j >= j0 && j <= j1 && i + j >= s0 && i + j <= s1 && i - j >= d0 && i - j <= d1;
  }
  // Counter-clockwise from the lower end of the side i = i1; a side may have length zero.
  std::array<Node, 8> vertices() const {
    return {Node(i1, i1 - d1), Node(i1, s1 - i1), Node(s1 - j1, j1), Node(d0 + j1, j1),
            Node(i0, i0 - d0), Node(i0, s0 - i0), Node(s0 - j0, j0), Node(d1 + j0, j0)};
  }
};

// Side directions of an Octagon, in the order of its vertices.
constexpr std::array<std::array<int, 2>, 8> kOctagonSides{
    {{0, 1}, {-1, 1}, {-1, 0}, {-1, -1}, {0, -1}, {1, -1}, {1, 0}, {1, 1}}};

Octagon octagon_around(const VerticalHole& hole, const Grid& grid, double h) {
  const double hx = grid.x.back() / grid.cells_x(), hy = grid.y.back() / grid.cells_y();
  const double gx = hole.x / hx, gy = hole.y / hy;
  // Two rings' room beyond the rim, more for large holes so the octagon's corners (8 % farther out
  // than its sides) stay a small part of the spoke length.
  const double reach = hole.radius + std::max(2 * h, 0.3 * hole.radius);
  const double diagonal_reach = reach * std::hypot(1 / hx, 1 / hy);  // the same distance in units of i ± j
  // A slot's octagon is the round one stretched by half the slot's length either way along x (and so
  // along both diagonals); for a round hole half is 0 and every bound is the round one to the bit.
  const double half = hole.slot_length / 2;
  const auto nearest = [](double v) { return static_cast<int>(std::lround(v)); };
  // Near the box sides the octagon is clipped to the face; its outline then runs along the face edge.
  const Octagon o{std::max(0, nearest(gx - (half + reach) / hx)),
                  std::min(grid.cells_x(), nearest(gx + (half + reach) / hx)),
                  std::max(0, nearest(gy - reach / hy)),
                  std::min(grid.cells_y(), nearest(gy + reach / hy)),
                  nearest(gx + gy - half / hx - diagonal_reach),
                  nearest(gx + gy + half / hx + diagonal_reach),
                  nearest(gx - gy - half / hx - diagonal_reach),
                  nearest(gx - gy + half / hx + diagonal_reach)};
  const auto v = o.vertices();
  for (std::size_t k = 0; k < v.size(); ++k) {
    const Node step = v[(k + 1) % v.size()] - v[k];
    if (step.x() * kOctagonSides[k][0] + step.y() * kOctagonSides[k][1] < 0)
      throw std::invalid_argument("mesh_box_with_holes: edge length too coarse for a hole");
  }
  return o;
}

// The octagon's outline through every grid node on it, counter-clockwise.
Polygon2 octagon_outline(const Octagon& o, const Grid& grid) {
  Polygon2 outline;
  const auto v = o.vertices();
  for (std::size_t k = 0; k < v.size(); ++k) {
    const Node delta = v[(k + 1) % v.size()] - v[k];
    const int steps = delta.cwiseAbs().maxCoeff();
    for (int t = 0; t < steps; ++t) outline.push_back(grid.node(v[k] + delta / steps * t));
  }
  return outline;
}

// The rectangle of grid nodes around the whole face (an octagon without diagonal sides), counter-clockwise.
Polygon2 face_outline(const Grid& grid) {
  return octagon_outline(Octagon{0, grid.cells_x(), 0, grid.cells_y(), 0, grid.cells_x() + grid.cells_y(),
                                 -grid.cells_y(), grid.cells_x()},
                         grid);
}

// A convex polygon around `centre`, looked up by polar angle, so that rim and outline points at equal
// angles give radial spokes.
class ConvexOutline {
 public:
  ConvexOutline(const Polygon2& points, const Point2& centre) : points_(points), centre_(centre) {
    double previous = angle_of(points_[0]);
    angles_.push_back(previous);
    for (std::size_t i = 1; i <= points_.size(); ++i) {
      double angle = angle_of(points_[i % points_.size()]);
      while (angle <= previous) angle += 2 * std::numbers::pi;
      angles_.push_back(previous = angle);
    }
  }
  double start_angle() const { return angles_.front(); }
  // The outline point in direction `angle` ∈ [start_angle, start_angle + 2π).
  Point2 at(double angle) const {
    const auto i = std::upper_bound(angles_.begin(), angles_.end(), angle) - angles_.begin() - 1;
    const Point2 a = points_[i], edge = points_[(i + 1) % points_.size()] - a;
    const Point2 ray(std::cos(angle), std::sin(angle));
    const auto cross = [](const Point2& u, const Point2& v) { return u.x() * v.y() - u.y() * v.x(); };
    return centre_ + cross(a - centre_, edge) / cross(ray, edge) * ray;
  }

 private:
  double angle_of(const Point2& p) const { return std::atan2(p.y() - centre_.y(), p.x() - centre_.x()); }
  const Polygon2& points_;
  Point2 centre_;
  std::vector<double> angles_;  // unwrapped, increasing, closing with the first point's angle + 2π
};

// Rings from the rim (front, exactly on the circle) out to the octagon outline (back), all
// counter-clockwise, each with about one point per h of its length.
std::vector<Polygon2> hole_rings(const VerticalHole& hole, const Polygon2& outline, double h) {
  const Point2 centre(hole.x, hole.y);
  const double r = hole.radius;
  const ConvexOutline outer(outline, centre);
  double mean_spoke = 0, outline_length = 0, nearest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < outline.size(); ++i) {
    const Point2 a = outline[i], edge = outline[(i + 1) % outline.size()] - a;
    const double along = std::clamp((centre - a).dot(edge) / edge.squaredNorm(), 0.0, 1.0);
    nearest = std::min(nearest, (a + along * edge - centre).norm());
    mean_spoke += ((a - centre).norm() - r) / static_cast<double>(outline.size());
    outline_length += edge.norm();
  }
  if (nearest < r + 0.5 * h)
    throw std::invalid_argument("mesh_box_with_holes: a hole is too close to the box side for this edge length");

  // Ring k blends rim and outline along each spoke with weight k / ring_count; odd rings are twisted
  // by half a step, which zips equal-count neighbours into near-equilateral triangles.
  const int ring_count = std::max(1, static_cast<int>(std::lround(mean_spoke / h)));
  std::vector<Polygon2> rings;
  for (int k = 0; k < ring_count; ++k) {
    const double t = static_cast<double>(k) / ring_count;
    const double length = (1 - t) * 2 * std::numbers::pi * r + t * outline_length;
    const int n = std::max(3, static_cast<int>(std::lround(length / h)));
    const double twist = k % 2 == 1 ? 0.5 : 0.0;
    Polygon2 ring;
    for (int i = 0; i < n; ++i) {
      const double angle = outer.start_angle() + 2 * std::numbers::pi * (i + twist) / n;
      const Point2 rim = centre + r * Point2(std::cos(angle), std::sin(angle));
      ring.push_back(k == 0 ? rim : Point2((1 - t) * rim + t * outer.at(angle)));
    }
    rings.push_back(std::move(ring));
  }
  rings.push_back(outline);
  return rings;
}

// Where the ray from `origin` (inside the convex counter-clockwise polygon) along `direction` leaves it.
Point2 exit_point(const Point2& origin, const Point2& direction, const Polygon2& polygon) {
  const auto cross = [](const Point2& u, const Point2& v) { return u.x() * v.y() - u.y() * v.x(); };
  double nearest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Point2 a = polygon[i], edge = polygon[(i + 1) % polygon.size()] - a;
    const double across = cross(direction, edge);
    if (across > 0) nearest = std::min(nearest, cross(a - origin, edge) / across);  // leaving this side's half plane
  }
  return origin + nearest * direction;
}

// A slot's rings, as hole_rings makes a round hole's, but along the rim's outward normals instead of
// rays from one centre: on the straight sides the normals are parallel, so polar angles would crowd
// the rim points at the middle of the sides and starve its ends. Normal rays of a convex rim never
// cross outside it, so every ring between rim and octagon stays simple. The rim ring is spaced evenly
// by arc length (its points exactly on the true edge), the others evenly by their own length.
std::vector<Polygon2> slot_rings(const VerticalHole& hole, const Polygon2& outline, double h) {
  const SlotRim rim(hole);
  const double r = hole.radius;
  double mean_spoke = 0, outline_length = 0, nearest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < outline.size(); ++i) {
    const Point2 a = outline[i], edge = outline[(i + 1) % outline.size()] - a;
    // The side's nearest approach to the axis segment: at an end of one or the other.
    for (const Point2& end : {Point2(hole.x - hole.slot_length / 2, hole.y), Point2(hole.x + hole.slot_length / 2, hole.y)}) {
      const double along = std::clamp((end - a).dot(edge) / edge.squaredNorm(), 0.0, 1.0);
      nearest = std::min(nearest, (a + along * edge - end).norm());
    }
    nearest = std::min(nearest, rim.axis_distance(a));
    mean_spoke += (rim.axis_distance(a) - r) / static_cast<double>(outline.size());
    outline_length += edge.norm();
  }
  if (nearest < r + 0.5 * h)
    throw std::invalid_argument("mesh_box_with_holes: a slot is too close to the box side for this edge length");

  const double perimeter = rim.perimeter(), start = rim.arc_length_toward(outline.front());
  const auto on_outline = [&](double s) {
    const SlotRim::Station station = rim.at(s);
    return exit_point(station.axis, station.normal, outline);
  };
  const int ring_count = std::max(1, static_cast<int>(std::lround(mean_spoke / h)));
  // Each ring's length, tabulated finely enough that interpolating it misplaces a point by far less than h.
  const int table = std::max(256, 32 * static_cast<int>(std::ceil(outline_length / h)));
  std::vector<Polygon2> rings;
  for (int k = 0; k < ring_count; ++k) {
    const double t = static_cast<double>(k) / ring_count;
    const auto ring_point = [&](double s) {
      return k == 0 ? rim.point(s) : Point2((1 - t) * rim.point(s) + t * on_outline(s));
    };
    std::vector<double> travelled{0};  // along ring k, at s = start + perimeter · m / table
    if (k > 0) {
      Point2 previous = ring_point(start);
      for (int m = 1; m <= table; ++m) {
        const Point2 next = ring_point(start + perimeter * m / table);
        travelled.push_back(travelled.back() + (next - previous).norm());
        previous = next;
      }
    }
    const double length = k == 0 ? perimeter : travelled.back();
    const int n = std::max(3, static_cast<int>(std::lround(length / h)));
    const double twist = k % 2 == 1 ? 0.5 : 0.0;
    Polygon2 ring;
    for (int i = 0; i < n; ++i) {
      const double target = length * (i + twist) / n;
      double s = start + perimeter * (i + twist) / n;  // the rim ring: arc length is the parameter
      if (k > 0) {
        const auto m = std::min<std::ptrdiff_t>(
            std::upper_bound(travelled.begin(), travelled.end(), target) - travelled.begin(), table);
        const double low = travelled[m - 1], high = travelled[m];
        s = start + perimeter * (m - 1 + (high > low ? (target - low) / (high - low) : 0.0)) / table;
      }
      ring.push_back(ring_point(s));
    }
    rings.push_back(std::move(ring));
  }
  rings.push_back(outline);
  return rings;
}

// Plain cells as two triangles, cells an octagon cuts as the triangle outside it, and the rings.
std::vector<Triangle2> face_pattern(const Grid& grid, const std::vector<Octagon>& octagons,
                                    const std::vector<std::vector<Polygon2>>& rings) {
  std::vector<Triangle2> triangles;
  for (int i = 0; i < grid.cells_x(); ++i)
    for (int j = 0; j < grid.cells_y(); ++j) {
      const std::array<Node, 4> corners{Node(i, j), Node(i + 1, j), Node(i + 1, j + 1), Node(i, j + 1)};
      const std::array<Point2, 4> p{grid.node(corners[0]), grid.node(corners[1]), grid.node(corners[2]),
                                    grid.node(corners[3])};
      int claims = 0, inside = 0;
      std::size_t outside = 0;  // the corner a cut cell keeps outside its octagon
      for (const Octagon& o : octagons) {
        int n = 0;
        std::size_t last_out = 0;
        for (std::size_t c = 0; c < 4; ++c) {
          if (o.contains(corners[c].x(), corners[c].y()))
            ++n;
          else
            last_out = c;
        }
        if (n < 3) continue;
        ++claims;
        inside = n;
        outside = last_out;
      }
      if (claims > 1) throw std::invalid_argument("mesh_box_with_holes: holes too close for this edge length");
      if (claims == 0) {
        // Alternating diagonals keep the pattern free of a preferred direction.
        if ((i + j) % 2 == 0) {
          triangles.push_back({p[0], p[1], p[2]});
          triangles.push_back({p[0], p[2], p[3]});
        } else {
          triangles.push_back({p[0], p[1], p[3]});
          triangles.push_back({p[1], p[2], p[3]});
        }
      } else if (inside == 3) {
        triangles.push_back({p[(outside + 3) % 4], p[outside], p[(outside + 1) % 4]});
      }
    }
  for (const std::vector<Polygon2>& hole : rings)
    for (std::size_t k = 0; k + 1 < hole.size(); ++k) {
      const Polygon2 &outer = hole[k + 1], &inner = hole[k];
      const auto point = [&](int c) {
        const auto n = static_cast<int>(outer.size());
        return c < n ? outer[c] : inner[c - n];
      };
      for (const auto& t : zip_rings(outer, inner)) triangles.push_back({point(t[0]), point(t[1]), point(t[2])});
    }
  return triangles;
}

Vec3 at_height(const Point2& p, double z) { return {p.x(), p.y(), z}; }

// A vertical wall along a closed polygon whose outward side is to the right of its direction of travel.
void add_wall(MeshBuilder& mesh, const Polygon2& polygon, const std::vector<double>& zs) {
  const std::size_t n = polygon.size();
  for (std::size_t l = 0; l + 1 < zs.size(); ++l)
    for (std::size_t i = 0; i < n; ++i) {
      const Point2 &a = polygon[i], &b = polygon[(i + 1) % n];
      mesh.quad(at_height(a, zs[l]), at_height(b, zs[l]), at_height(b, zs[l + 1]), at_height(a, zs[l + 1]),
                (i + l) % 2 == 0);
    }
}

}  // namespace

TriangleMesh mesh_box_with_holes(const Vec3& size, const std::vector<VerticalHole>& holes, double edge_length) {
  for (const VerticalHole& hole : holes)
    if (!(hole.slot_length >= 0) || !std::isfinite(hole.slot_length))
      throw std::invalid_argument("mesh_box_with_holes: a slot_length is negative or not finite");
  const Grid grid{grid_lines(size.x(), edge_length), grid_lines(size.y(), edge_length),
                  grid_lines(size.z(), edge_length)};
  std::vector<Octagon> octagons;
  std::vector<std::vector<Polygon2>> rings;
  for (const VerticalHole& hole : holes) {
    octagons.push_back(octagon_around(hole, grid, edge_length));
    const Polygon2 outline = octagon_outline(octagons.back(), grid);
    rings.push_back(hole.slot_length > 0 ? slot_rings(hole, outline, edge_length) : hole_rings(hole, outline, edge_length));
  }

  MeshBuilder mesh;
  for (const Triangle2& t : face_pattern(grid, octagons, rings)) {
    mesh.triangle(mesh.vertex(at_height(t[0], size.z())), mesh.vertex(at_height(t[1], size.z())),
                  mesh.vertex(at_height(t[2], size.z())));
    mesh.triangle(mesh.vertex(at_height(t[0], 0.0)), mesh.vertex(at_height(t[2], 0.0)),
                  mesh.vertex(at_height(t[1], 0.0)));
  }
  add_wall(mesh, face_outline(grid), grid.z);
  for (const std::vector<Polygon2>& hole : rings) {
    // The bore's outward side faces the axis: walk the rim clockwise.
    add_wall(mesh, Polygon2(hole.front().rbegin(), hole.front().rend()), grid.z);
  }
  return mesh.finish();
}

}  // namespace cmm::geometry
