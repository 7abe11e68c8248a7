// The analytic parts: meshes from the box and revolution meshers, exact sharp edges and holes from
// the defining dimensions (never from the mesh), and the seeded vertex noise.
#include "geometry/analytic_parts.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <utility>

#include "geometry/box_with_holes_mesher.hpp"
#include "geometry/box_with_holes_slot.hpp"
#include "geometry/edge_point.hpp"
#include "geometry/revolved_mesher.hpp"

namespace cmm::geometry {
namespace {

using Point2 = Eigen::Vector2d;

// 0.05 mm keeps the chord error between samples of the smallest circle (a slot's end, r = 1 mm) near 0.3 µm.
constexpr double kSampleSpacing = 0.05;

// Orders the two side normals by the same n_up convention the extractor uses.
TrueEdgeSample edge_sample(const Vec3& position, const Vec3& a, const Vec3& b) {
  return is_up_side(a, b) ? TrueEdgeSample{position, a, b} : TrueEdgeSample{position, b, a};
}

TrueEdge straight_edge(const Vec3& from, const Vec3& to, const Vec3& normal_a, const Vec3& normal_b) {
  const int n = static_cast<int>(std::ceil((to - from).norm() / kSampleSpacing));
  TrueEdge edge;
  for (int i = 0; i <= n; ++i) {
    const Vec3 p = i == n ? to : Vec3(from + (to - from) * (static_cast<double>(i) / n));
    edge.samples.push_back(edge_sample(p, normal_a, normal_b));
  }
  return edge;
}

// A horizontal circle; side_normals(u) gives the two normals at the point in radial direction u.
template <class SideNormals>
TrueEdge circular_edge(const Vec3& centre, double radius, SideNormals side_normals) {
  const int n = static_cast<int>(std::ceil(2 * std::numbers::pi * radius / kSampleSpacing));
  TrueEdge edge;
  edge.closed = true;
  for (int i = 0; i < n; ++i) {
    const double angle = 2 * std::numbers::pi * i / n;
    const Vec3 u(std::cos(angle), std::sin(angle), 0);
    const auto [a, b] = side_normals(u);
    edge.samples.push_back(edge_sample(centre + radius * u, a, b));
  }
  return edge;
}

// A slot's rim at height z on the face whose normal is `face`; the wall's outward normal points into
// the slot, against the rim's outward normal.
TrueEdge slot_edge(const VerticalHole& hole, double z, const Vec3& face) {
  const SlotRim rim(hole);
  const int n = static_cast<int>(std::ceil(rim.perimeter() / kSampleSpacing));
  TrueEdge edge;
  edge.closed = true;
  for (int i = 0; i < n; ++i) {
    const double s = rim.perimeter() * i / n;
    const SlotRim::Station station = rim.at(s);
    const Point2 p = rim.point(s);
    edge.samples.push_back(edge_sample(Vec3(p.x(), p.y(), z), face, Vec3(-station.normal.x(), -station.normal.y(), 0)));
  }
  return edge;
}

int segments_for(double radius, const Tessellation& t) {
  const int cad = circle_segments(radius, t.chord_tolerance);
  if (t.style == Tessellation::Style::slivers) return std::max(cad, radius > 20 ? 720 : 180);
  return cad;
}

TriangleMesh box_mesh(const Vec3& size, const std::vector<VerticalHole>& holes, const Tessellation& t) {
  if (t.style == Tessellation::Style::uniform) return mesh_box_with_holes(size, holes, t.edge_length);
  std::vector<int> segments;
  for (const VerticalHole& hole : holes) segments.push_back(segments_for(hole.radius, t));
  return mesh_box_with_holes_cad(size, holes, segments, t.style == Tessellation::Style::slivers ? 0.5 : 0.0);
}

AnalyticPart box_part(std::string name, const Vec3& size, const std::vector<VerticalHole>& holes, const Tessellation& t) {
  AnalyticPart part{std::move(name), box_mesh(size, holes, t), {}, {}, size.norm()};
  for (int axis = 0; axis < 3; ++axis) {
    const int b = (axis + 1) % 3, c = (axis + 2) % 3;
    for (int high_b : {0, 1})
      for (int high_c : {0, 1}) {
        Vec3 from = Vec3::Zero(), normal_b = Vec3::Zero(), normal_c = Vec3::Zero();
        from[b] = high_b ? size[b] : 0.0;
        from[c] = high_c ? size[c] : 0.0;
        normal_b[b] = high_b ? 1.0 : -1.0;
        normal_c[c] = high_c ? 1.0 : -1.0;
        Vec3 to = from;
        to[axis] = size[axis];
        part.sharp_edges.push_back(straight_edge(from, to, normal_b, normal_c));
      }
  }
  const Vec3 up = Vec3::UnitZ();
  for (const VerticalHole& hole : holes) {
    if (hole.slot_length > 0) {
      // A slot's two rims; it is no cylinder, so it is not among the part's holes.
      part.sharp_edges.push_back(slot_edge(hole, size.z(), up));
      part.sharp_edges.push_back(slot_edge(hole, 0.0, -up));
      continue;
    }
    const Vec3 bottom_centre(hole.x, hole.y, 0), top_centre(hole.x, hole.y, size.z());
    // The bore's outward normal points at the axis.
    part.sharp_edges.push_back(circular_edge(top_centre, hole.radius, [&](const Vec3& u) {
      return std::pair{up, Vec3(-u)};
    }));
    part.sharp_edges.push_back(circular_edge(bottom_centre, hole.radius, [&](const Vec3& u) {
      return std::pair{Vec3(-up), Vec3(-u)};
    }));
    part.holes.push_back({top_centre, up, hole.radius, size.z()});
  }
  return part;
}

// Points of the segment from → to about h apart, excluding `from` (the previous piece ended there).
void append_segment(std::vector<Point2>& profile, const Point2& from, const Point2& to, double h) {
  const int n = std::max(1, static_cast<int>(std::lround((to - from).norm() / h)));
  for (int i = 1; i < n; ++i) profile.push_back(from + (to - from) * (static_cast<double>(i) / n));
  profile.push_back(to);
}

// Outward unit normal, at radial direction u, of a cone of rim radius r whose apex lies `rise` above
// the rim plane (below it when negative).
Vec3 cone_normal(const Vec3& u, double r, double rise) {
  return (std::abs(rise) * u + std::copysign(r, rise) * Vec3::UnitZ()).normalized();
}

// The profile of a surface of revolution: its straight pieces cut into edge_length steps for a uniform
// mesh, left whole for a CAD one (a cone is then an apex fanned to its rim).
void append_piece(std::vector<Point2>& profile, const Point2& from, const Point2& to, const Tessellation& t) {
  if (t.style == Tessellation::Style::uniform) append_segment(profile, from, to, t.edge_length);
  else profile.push_back(to);
}

TriangleMesh revolved_mesh(const std::vector<Point2>& profile, double rim_radius, const Tessellation& t) {
  if (t.style == Tessellation::Style::uniform) return mesh_revolved_profile(profile, t.edge_length);
  return mesh_revolved_profile_cad(profile, segments_for(rim_radius, t));
}

}  // namespace

int circle_segments(double radius, double chord_tolerance) {
  if (!(chord_tolerance > 0) || chord_tolerance >= radius) return 3;
  return std::max(3, static_cast<int>(std::ceil(std::numbers::pi / std::acos(1 - chord_tolerance / radius))));
}

// The cube is [0, side]³: a corner at the origin, standing on z = 0.
AnalyticPart make_cube(double side_mm, double edge_length) { return make_cube(side_mm, Tessellation{.edge_length = edge_length}); }
AnalyticPart make_cube(double side_mm, const Tessellation& t) { return box_part("cube", Vec3::Constant(side_mm), {}, t); }

// Ø42 at (44, 47.5), Ø10 at (13, 12.5), (75, 12.5), (13, 82.5) and (75, 82.5): the small holes in
// the corners, 7.5 mm of wall to the 88 mm sides, 8 mm to the 95 mm sides, 20.8 mm to the big hole.
// Meshes for edge_length up to about 4.5 mm.
AnalyticPart make_case3_block(double edge_length) { return make_case3_block(Tessellation{.edge_length = edge_length}); }
AnalyticPart make_case3_block(const Tessellation& t) {
  return box_part("case3_block", Vec3(88, 95, 41),
                  {{44, 47.5, 21}, {13, 12.5, 5}, {75, 12.5, 5}, {13, 82.5, 5}, {75, 82.5, 5}}, t);
}

// Ø20 at (30, 40), Ø12 at (70, 25) and (70, 55), Ø6 at (100, 20), Ø8 at (100, 60): rims at least
// 18 mm apart and 16 mm from the sides. Meshes for edge_length up to about 4.5 mm.
AnalyticPart make_plate_with_holes(double edge_length) { return make_plate_with_holes(Tessellation{.edge_length = edge_length}); }
AnalyticPart make_plate_with_holes(const Tessellation& t) {
  return box_part("plate_with_holes", Vec3(120, 80, 10),
                  {{30, 40, 10}, {70, 25, 6}, {70, 55, 6}, {100, 20, 3}, {100, 60, 4}}, t);
}

// The plate above plus a Ø3 hole at (10, 70) and a 2 × 10 mm slot centred at (40, 10) along x: the
// small true openings a scan's mesh must keep open. Each rim is at least 8.5 mm from the plate's sides
// and 19 mm from the other rims, so it meshes wherever the plate does (edge_length up to about 5 mm).
AnalyticPart make_plate_small_openings(double edge_length) {
  return make_plate_small_openings(Tessellation{.edge_length = edge_length});
}
AnalyticPart make_plate_small_openings(const Tessellation& t) {
  return box_part("plate_small_openings", Vec3(120, 80, 10),
                  {{30, 40, 10}, {70, 25, 6}, {70, 55, 6}, {100, 20, 3}, {100, 60, 4}, {10, 70, 1.5}, {40, 10, 1, 8}}, t);
}

// Apexes at the origin and at (0, 0, 2H), rim at z = H; each apex is one vertex fanned to its ring.
AnalyticPart make_bicone(double radius_mm, double height_mm, double edge_length) {
  return make_bicone(radius_mm, height_mm, Tessellation{.edge_length = edge_length});
}
AnalyticPart make_bicone(double radius_mm, double height_mm, const Tessellation& t) {
  const double r = radius_mm, h = height_mm;
  std::vector<Point2> profile{{0, 0}};
  append_piece(profile, {0, 0}, {r, h}, t);
  append_piece(profile, {r, h}, {0, 2 * h}, t);
  AnalyticPart part{"bicone", revolved_mesh(profile, r, t), {}, {}, 2 * std::sqrt(2 * r * r + h * h)};
  part.sharp_edges.push_back(circular_edge(Vec3(0, 0, h), r, [&](const Vec3& u) {
    return std::pair{cone_normal(u, r, h), cone_normal(u, r, -h)};
  }));
  return part;
}

// Hemisphere centred at (0, 0, R): pole at the origin, rim at z = R; apex at (0, 0, R + H).
AnalyticPart make_hemisphere_cone(double radius_mm, double height_mm, double edge_length) {
  return make_hemisphere_cone(radius_mm, height_mm, Tessellation{.edge_length = edge_length});
}
AnalyticPart make_hemisphere_cone(double radius_mm, double height_mm, const Tessellation& t) {
  const double r = radius_mm, h = height_mm;
  // A CAD system steps the meridian by the same chord tolerance as the rings.
  const int arc_steps = t.style == Tessellation::Style::uniform
                            ? std::max(1, static_cast<int>(std::lround(std::numbers::pi / 2 * r / t.edge_length)))
                            : std::max(1, (circle_segments(r, t.chord_tolerance) + 3) / 4);
  std::vector<Point2> profile;
  for (int i = 0; i < arc_steps; ++i) {
    const double polar = std::numbers::pi / 2 * i / arc_steps;
    profile.emplace_back(r * std::sin(polar), r - r * std::cos(polar));
  }
  profile.emplace_back(r, r);
  append_piece(profile, {r, r}, {0, r + h}, t);
  AnalyticPart part{"hemisphere_cone", revolved_mesh(profile, r, t), {}, {}, std::sqrt(8 * r * r + (r + h) * (r + h))};
  part.sharp_edges.push_back(circular_edge(Vec3(0, 0, r), r, [&](const Vec3& u) {
    return std::pair{cone_normal(u, r, h), u};
  }));
  return part;
}

TriangleMesh with_gaussian_noise(const TriangleMesh& mesh, double sigma_mm, std::uint64_t seed) {
  std::mt19937_64 engine(seed);
  std::normal_distribution<double> noise(0.0, sigma_mm);
  TriangleMesh noisy{mesh.vertices, mesh.faces, Points(0, 3)};
  for (Eigen::Index v = 0; v < noisy.vertices.rows(); ++v)
    for (int k = 0; k < 3; ++k) noisy.vertices(v, k) += noise(engine);
  return noisy;
}

const std::vector<std::string>& analytic_part_names() {
  static const std::vector<std::string> names = {"cube",   "case3_block",    "plate_with_holes", "plate_small_openings",
                                                 "bicone", "hemisphere_cone"};
  return names;
}

AnalyticPart make_analytic_part(const std::string& name, double edge_length) {
  return make_analytic_part(name, Tessellation{.edge_length = edge_length});
}

AnalyticPart make_analytic_part(const std::string& name, const Tessellation& t) {
  if (name == "cube") return make_cube(40, t);
  if (name == "case3_block") return make_case3_block(t);
  if (name == "plate_with_holes") return make_plate_with_holes(t);
  if (name == "plate_small_openings") return make_plate_small_openings(t);
  if (name == "bicone") return make_bicone(25, 37.5, t);
  if (name == "hemisphere_cone") return make_hemisphere_cone(25, 25, t);
  std::string known;
  for (const auto& n : analytic_part_names()) known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown analytic part \"" + name + "\" (known: " + known + ")");
}

}  // namespace cmm::geometry
