// Reads and checks plate.json, and answers the geometric questions about the nominal plate: side
// normals, where the fiducial is, which relabellings of the corners look the same.
#include "hal/description/plate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Geometry>

#include "hal/description/eigen_json.hpp"
#include "hal/description/json_fields.hpp"

namespace cmm::description {
namespace detail {
extern const char* const default_plate_json;
}

namespace {

std::string mm(double value) {
  char text[64];
  std::snprintf(text, sizeof text, "%.2f", value);
  return text;
}

// Signed distance of (x, y) from the side id → next(id), positive inside the plate.
double inside_distance(const Plate& plate, int id, const Eigen::Vector2d& xy) {
  const Vec3 n = side_normal(plate, id);
  const Vec3& c = plate.corner(id);
  return -(n.x() * (xy.x() - c.x()) + n.y() * (xy.y() - c.y()));
}

int shifted(const Plate& plate, int id, int k) { return (id - 1 + k) % plate.corner_count() + 1; }

// The rigid motion of the plane that takes corner i to corner i + k for a shift that symmetry_shifts
// found: a turn about the corners' centroid (which the relabelled set shares), by the angle between a
// side and its image.
Eigen::Vector2d turned(const Plate& plate, int k, const Eigen::Vector2d& p) {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const Vec3& c : plate.corners) centroid += c.head<2>();
  centroid /= plate.corner_count();
  const Eigen::Vector2d side = (plate.corner(2) - plate.corner(1)).head<2>();
  const Eigen::Vector2d image = (plate.corner(shifted(plate, 2, k)) - plate.corner(shifted(plate, 1, k))).head<2>();
  const double angle = std::atan2(image.y(), image.x()) - std::atan2(side.y(), side.x());
  return centroid + Eigen::Rotation2Dd(angle) * (p - centroid);
}

// The corners' shape: one height, a convex counter-clockwise outline, no coincident corners.
void check_outline(const Plate& plate, JsonFields& f, std::vector<JsonFields>& corner_fields) {
  const int n = plate.corner_count();
  double extent = 0;
  for (int a = 1; a <= n; ++a)
    for (int b = a + 1; b <= n; ++b) extent = std::max(extent, (plate.corner(a) - plate.corner(b)).norm());
  for (int id = 2; id <= n; ++id)
    if (std::abs(plate.corner(id).z() - plate.top_z()) > 1e-6)
      corner_fields[static_cast<std::size_t>(id - 1)].problem("every corner lies on the top face: z " +
                                                              mm(plate.corner(id).z()) + " differs from corner 1's " +
                                                              mm(plate.top_z()));
  for (int id = 1; id <= n; ++id) {
    const Vec3 in = plate.corner(id) - plate.corner(plate.previous(id));
    const Vec3 out = plate.corner(plate.next(id)) - plate.corner(id);
    if (out.norm() <= 1e-6 * extent || extent == 0) {
      f.problem("corners", "corners " + std::to_string(id) + " and " + std::to_string(plate.next(id)) + " coincide");
      return;
    }
    const double turn = in.x() * out.y() - in.y() * out.x();
    if (!(turn > 1e-9 * extent * extent)) {
      f.problem("corners", "corner " + std::to_string(id) +
                               (turn < 0 ? " turns clockwise: list the corners counter-clockwise seen from the top "
                                           "(+z), forming a convex outline"
                                         : " lies on the line of its neighbours"));
      return;
    }
  }
}

void read_chamfer(JsonFields& f, Plate& plate) {
  PlateFiducial& fiducial = plate.fiducial;
  const int n = plate.corner_count();
  fiducial.kind = PlateFiducial::Kind::chamfer;
  if (f.require("corner", "the corner id, 1 … " + std::to_string(n)))
    fiducial.corner = f.integer("corner", 0, std::numeric_limits<int>::min(), std::numeric_limits<int>::max());
  if (f.require("size_mm")) fiducial.size_mm = f.positive("size_mm", fiducial.size_mm);
  f.finish();
  if (!f.ok()) return;
  if (fiducial.corner < 1 || fiducial.corner > n) {
    f.problem("corner", std::to_string(fiducial.corner) + " is not a corner id (1 … " + std::to_string(n) + ")");
    return;
  }
  const int c = fiducial.corner;
  const double shortest = std::min((plate.corner(plate.next(c)) - plate.corner(c)).norm(),
                                   (plate.corner(plate.previous(c)) - plate.corner(c)).norm());
  if (!(fiducial.size_mm < shortest / 2))
    f.problem("size_mm", mm(fiducial.size_mm) + " mm is more than half the shortest side at corner " +
                             std::to_string(c) + " (" + mm(shortest) + " mm)");
}

void read_hole(JsonFields& f, Plate& plate) {
  PlateFiducial& fiducial = plate.fiducial;
  fiducial.kind = PlateFiducial::Kind::hole;
  if (f.require("centre", "[x, y] of the hole's axis in the plate frame")) {
    JsonFields centre = f.member("centre");
    if (centre.value().is_array() && centre.value().size() != 2) centre.problem("must be [x, y]");
    else fiducial.centre = centre.as_vec3(Vec3::Zero(), true).head<2>();
  }
  if (f.require("diameter_mm")) fiducial.diameter_mm = f.positive("diameter_mm", fiducial.diameter_mm);
  fiducial.depth_mm = f.positive("depth_mm", 0);
  f.finish();
  if (!f.ok()) return;
  if (fiducial.depth_mm > plate.thickness_mm) {
    f.problem("depth_mm", mm(fiducial.depth_mm) + " mm is deeper than the plate (" + mm(plate.thickness_mm) + " mm)");
    return;
  }
  if (fiducial.depth_mm == 0) fiducial.depth_mm = plate.thickness_mm;
  for (int id = 1; id <= plate.corner_count(); ++id)
    if (!(inside_distance(plate, id, fiducial.centre) > fiducial.diameter_mm / 2)) {
      f.problem("centre", "the hole does not fit inside the plate: it reaches the side corner " + std::to_string(id) +
                              "–corner " + std::to_string(plate.next(id)));
      return;
    }
  // A hole that the plate's own symmetry maps onto itself cannot tell the corners apart.
  for (int k : symmetry_shifts(plate))
    if ((turned(plate, k, fiducial.centre) - fiducial.centre).norm() < fiducial.diameter_mm) {
      f.problem("centre", "the hole sits where the plate's symmetry (corner 1 onto corner " + std::to_string(1 + k) +
                              ") maps it onto itself, so it cannot tell those corners apart: move it toward one corner");
      return;  // one symmetry says it; a square's three would say it three times
    }
}

}  // namespace

const char* to_string(PlateFiducial::Kind kind) {
  switch (kind) {
    case PlateFiducial::Kind::chamfer: return "chamfer";
    case PlateFiducial::Kind::hole: return "hole";
  }
  return "?";
}

Vec3 side_normal(const Plate& plate, int id) {
  const Vec3 edge = plate.corner(plate.next(id)) - plate.corner(id);
  // Counter-clockwise seen from +z, the material lies to the left of each edge; outward is right.
  return Vec3(edge.y(), -edge.x(), 0).normalized();
}

Plate plate_from_json(const nlohmann::json& j, const std::string& source) {
  JsonFields f(j);
  Plate plate;
  if (!f.expect_object()) f.throw_if_problems(source);
  plate.name = f.text("name", "");
  f.text("description", "");  // for the reader of the file
  std::vector<JsonFields> corners;
  if (f.require("corners", "nominal corners [x, y, z] in the plate frame")) {
    corners = f.items("corners");
    if (f.value()["corners"].is_array() && corners.size() < 3)
      f.problem("corners", "must hold at least three corners");
    for (JsonFields& c : corners) plate.corners.push_back(c.as_vec3(Vec3::Zero(), true));
  }
  if (f.require("thickness_mm")) plate.thickness_mm = f.positive("thickness_mm", plate.thickness_mm);
  if (f.ok()) check_outline(plate, f, corners);
  const bool outline_ok = f.ok();
  if (f.require("fiducial", "a plate needs one asymmetric fiducial (chamfer or hole) to fix its corner order")) {
    JsonFields fiducial = f.object("fiducial");
    std::string kind;
    if (fiducial.value().is_object() && fiducial.require("kind", "\"chamfer\" or \"hole\""))
      kind = fiducial.text("kind", "", {"chamfer", "hole"});
    // Where a fiducial may be depends on the outline: with a bad one it is not looked at further.
    if (outline_ok && kind == "chamfer") read_chamfer(fiducial, plate);
    if (outline_ok && kind == "hole") read_hole(fiducial, plate);
  }
  f.finish();
  f.throw_if_problems(source);
  return plate;
}

Plate read_plate(const std::filesystem::path& file) {
  return plate_from_json(read_json_file(file, "the plate description"), file.string());
}

Plate default_plate() { return plate_from_json(nlohmann::json::parse(detail::default_plate_json), "config/plate.json (built in)"); }

nlohmann::json to_json(const Plate& plate) {
  nlohmann::json corners = nlohmann::json::array();
  for (const Vec3& c : plate.corners) corners.push_back(vec3_json(c));
  nlohmann::json fiducial = {{"kind", to_string(plate.fiducial.kind)}};
  if (plate.fiducial.kind == PlateFiducial::Kind::chamfer) {
    fiducial["corner"] = plate.fiducial.corner;
    fiducial["size_mm"] = plate.fiducial.size_mm;
  } else {
    fiducial["centre"] = {plate.fiducial.centre.x(), plate.fiducial.centre.y()};
    fiducial["diameter_mm"] = plate.fiducial.diameter_mm;
    fiducial["depth_mm"] = plate.fiducial.depth_mm;
  }
  return {{"name", plate.name}, {"corners", corners}, {"thickness_mm", plate.thickness_mm}, {"fiducial", fiducial}};
}

FiducialGeometry fiducial_geometry(const Plate& plate) {
  FiducialGeometry g;
  const PlateFiducial& f = plate.fiducial;
  if (f.kind == PlateFiducial::Kind::chamfer) {
    const Vec3& c = plate.corner(f.corner);
    const Vec3 a = c + f.size_mm * (plate.corner(plate.next(f.corner)) - c).normalized();
    const Vec3 b = c + f.size_mm * (plate.corner(plate.previous(f.corner)) - c).normalized();
    const Vec3 mid_top = (a + b) / 2;
    g.point = mid_top - plate.thickness_mm / 2 * Vec3::UnitZ();
    g.normal = (c - mid_top).normalized();  // the two legs are equal, so this is square to a − b
    g.along = (a - b).normalized();
    g.half_width_mm = (a - b).norm() / 2;
    g.bottom_z = plate.top_z() - plate.thickness_mm;
  } else {
    const double depth = f.depth_mm > 0 ? f.depth_mm : plate.thickness_mm;
    g.point = Vec3(f.centre.x(), f.centre.y(), plate.top_z() - depth / 2);
    g.normal = Vec3::UnitZ();
    g.half_width_mm = f.diameter_mm / 2;
    g.bottom_z = plate.top_z() - depth;
  }
  return g;
}

FiducialDeviation fiducial_deviation(const Plate& plate, const Vec3& p) {
  const FiducialGeometry g = fiducial_geometry(plate);
  const Vec3 d = p - g.point;
  FiducialDeviation deviation;
  double outside = std::max({0.0, g.bottom_z - p.z(), p.z() - plate.top_z()});
  if (plate.fiducial.kind == PlateFiducial::Kind::chamfer) {
    deviation.off_mm = std::abs(g.normal.dot(d));
    outside = std::max(outside, std::abs(g.along.dot(d)) - g.half_width_mm);
  } else {
    deviation.off_mm = d.head<2>().norm();
  }
  deviation.outside_mm = outside;
  return deviation;
}

// A relabelling that keeps every distance between corners is a rigid motion of the outline, and a
// proper one: it keeps the counter-clockwise order, which a mirror image would reverse.
std::vector<int> symmetry_shifts(const Plate& plate, double tolerance_mm) {
  const int n = plate.corner_count();
  std::vector<int> shifts;
  for (int k = 1; k < n; ++k) {
    bool same = true;
    for (int a = 1; a <= n && same; ++a)
      for (int b = a + 1; b <= n && same; ++b)
        same = std::abs((plate.corner(a) - plate.corner(b)).norm() -
                        (plate.corner(shifted(plate, a, k)) - plate.corner(shifted(plate, b, k))).norm()) <= tolerance_mm;
    if (same) shifts.push_back(k);
  }
  return shifts;
}

}  // namespace cmm::description
