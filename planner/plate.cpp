// Reads and checks plate.json, and answers the geometric questions registration and corner probing
// ask of the nominal plate: side normals, where the fiducial is, which relabellings look the same.
#include "planner/plate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <set>

#include "geometry/file_error.hpp"
#include "planner/json_fields.hpp"
#include "planner/number_text.hpp"
#include "planner/rigid_fit.hpp"

namespace cmm::planner {
namespace {

using geometry::FileError;
using nlohmann::json;

std::string mm(double value) { return fixed(value, 2); }

[[noreturn]] void fail(const std::string& source, const std::string& field, const std::string& message) {
  fail_field(source, field, message);
}


// [x, y] (z = 0) or [x, y, z].
Vec3 point(const json& j, const std::string& source, const std::string& field, bool allow_2d) {
  if (!j.is_array() || j.size() < (allow_2d ? 2u : 3u) || j.size() > 3)
    fail(source, field, allow_2d ? "expected [x, y] or [x, y, z]" : "expected [x, y, z]");
  Vec3 p = Vec3::Zero();
  static const char* axis[] = {"x", "y", "z"};
  for (std::size_t i = 0; i < j.size(); ++i) p(static_cast<int>(i)) = number(j[i], source, field + "." + axis[i]);
  return p;
}

// Signed distance of (x, y) from the side id → next(id), positive inside the plate.
double inside_distance(const Plate& plate, int id, const Eigen::Vector2d& xy) {
  const Vec3 n = side_normal(plate, id);
  const Vec3& c = plate.corner(id);
  return -(n.x() * (xy.x() - c.x()) + n.y() * (xy.y() - c.y()));
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

Plate plate_from_json(const json& j, const std::string& source) {
  if (!j.is_object()) fail(source, "plate", "expected an object");
  only_known_keys(j, source, "", {"name", "description", "corners", "thickness_mm", "fiducial"});
  Plate plate;
  if (j.contains("name")) {
    if (!j["name"].is_string()) fail(source, "name", "expected a string");
    plate.name = j["name"].get<std::string>();
  }
  if (!j.contains("corners")) fail(source, "corners", "missing (nominal corners [x, y, z] in the plate frame)");
  const json& corners = j["corners"];
  if (!corners.is_array() || corners.size() < 3) fail(source, "corners", "expected an array of at least three corners");
  for (std::size_t i = 0; i < corners.size(); ++i)
    plate.corners.push_back(point(corners[i], source, "corners[" + std::to_string(i) + "]", true));
  const int n = plate.corner_count();
  double extent = 0;
  for (int a = 1; a <= n; ++a)
    for (int b = a + 1; b <= n; ++b) extent = std::max(extent, (plate.corner(a) - plate.corner(b)).norm());
  for (int id = 2; id <= n; ++id)
    if (std::abs(plate.corner(id).z() - plate.top_z()) > 1e-6)
      fail(source, "corners[" + std::to_string(id - 1) + "].z",
           "every corner lies on the top face: z " + mm(plate.corner(id).z()) + " differs from corner 1's " +
               mm(plate.top_z()));
  for (int id = 1; id <= n; ++id) {
    const Vec3 in = plate.corner(id) - plate.corner(plate.previous(id));
    const Vec3 out = plate.corner(plate.next(id)) - plate.corner(id);
    if (out.norm() <= 1e-6 * extent || extent == 0)
      fail(source, "corners", "corners " + std::to_string(id) + " and " + std::to_string(plate.next(id)) + " coincide");
    const double turn = in.x() * out.y() - in.y() * out.x();
    if (!(turn > 1e-9 * extent * extent))
      fail(source, "corners",
           "corner " + std::to_string(id) +
               (turn < 0 ? " turns clockwise: list the corners counter-clockwise seen from the top (+z), "
                           "forming a convex outline"
                         : " lies on the line of its neighbours"));
  }
  if (!j.contains("thickness_mm")) fail(source, "thickness_mm", "missing");
  plate.thickness_mm = positive(j["thickness_mm"], source, "thickness_mm");

  if (!j.contains("fiducial"))
    fail(source, "fiducial", "missing: a plate needs one asymmetric fiducial (chamfer or hole) to fix its corner order");
  const json& f = j["fiducial"];
  if (!f.is_object() || !f.contains("kind") || !f["kind"].is_string())
    fail(source, "fiducial.kind", "expected \"chamfer\" or \"hole\"");
  const std::string kind = f["kind"].get<std::string>();
  PlateFiducial& fiducial = plate.fiducial;
  if (kind == "chamfer") {
    only_known_keys(f, source, "fiducial", {"kind", "corner", "size_mm"});
    fiducial.kind = PlateFiducial::Kind::chamfer;
    if (!f.contains("corner"))
      fail(source, "fiducial.corner", "expected the corner id (1 … " + std::to_string(n) + ")");
    fiducial.corner = integer(f["corner"], source, "fiducial.corner", std::numeric_limits<int>::min(),
                              std::numeric_limits<int>::max());
    if (fiducial.corner < 1 || fiducial.corner > n)
      fail(source, "fiducial.corner",
           std::to_string(fiducial.corner) + " is not a corner id (1 … " + std::to_string(n) + ")");
    if (!f.contains("size_mm")) fail(source, "fiducial.size_mm", "missing");
    fiducial.size_mm = positive(f["size_mm"], source, "fiducial.size_mm");
    const int c = fiducial.corner;
    const double shortest = std::min((plate.corner(plate.next(c)) - plate.corner(c)).norm(),
                                     (plate.corner(plate.previous(c)) - plate.corner(c)).norm());
    if (!(fiducial.size_mm < shortest / 2))
      fail(source, "fiducial.size_mm",
           mm(fiducial.size_mm) + " mm is more than half the shortest side at corner " + std::to_string(c) + " (" +
               mm(shortest) + " mm)");
  } else if (kind == "hole") {
    only_known_keys(f, source, "fiducial", {"kind", "centre", "diameter_mm", "depth_mm"});
    fiducial.kind = PlateFiducial::Kind::hole;
    if (!f.contains("centre")) fail(source, "fiducial.centre", "missing ([x, y] of the hole's axis in the plate frame)");
    const Vec3 centre = point(f["centre"], source, "fiducial.centre", true);
    if (f["centre"].size() != 2) fail(source, "fiducial.centre", "expected [x, y]");
    fiducial.centre = centre.head<2>();
    if (!f.contains("diameter_mm")) fail(source, "fiducial.diameter_mm", "missing");
    fiducial.diameter_mm = positive(f["diameter_mm"], source, "fiducial.diameter_mm");
    fiducial.depth_mm = f.contains("depth_mm") ? positive(f["depth_mm"], source, "fiducial.depth_mm") : 0.0;
    if (fiducial.depth_mm > plate.thickness_mm)
      fail(source, "fiducial.depth_mm",
           mm(fiducial.depth_mm) + " mm is deeper than the plate (" + mm(plate.thickness_mm) + " mm)");
    if (fiducial.depth_mm == 0) fiducial.depth_mm = plate.thickness_mm;
    for (int id = 1; id <= n; ++id)
      if (!(inside_distance(plate, id, fiducial.centre) > fiducial.diameter_mm / 2))
        fail(source, "fiducial.centre",
             "the hole does not fit inside the plate: it reaches the side corner " + std::to_string(id) + "–corner " +
                 std::to_string(plate.next(id)));
  } else {
    fail(source, "fiducial.kind", "\"" + kind + "\" is not a fiducial kind (chamfer, hole)");
  }

  // A fiducial that the plate's own symmetry maps onto itself cannot tell the corners apart.
  if (fiducial.kind == PlateFiducial::Kind::hole) {
    std::vector<Vec3> from(plate.corners.begin(), plate.corners.end()), to;
    for (int k : symmetry_shifts(plate)) {
      to.clear();
      for (int id = 1; id <= n; ++id) to.push_back(plate.corner((id - 1 + k) % n + 1));
      const Eigen::Isometry3d motion = fit_rigid(from, to).transform;
      const Vec3 centre(fiducial.centre.x(), fiducial.centre.y(), plate.top_z());
      if ((motion * centre - centre).norm() < fiducial.diameter_mm)
        fail(source, "fiducial.centre",
             "the hole sits where the plate's symmetry (corner 1 onto corner " + std::to_string(1 + k) +
                 ") maps it onto itself, so it cannot tell those corners apart: move it toward one corner");
    }
  }
  return plate;
}

Plate read_plate(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw FileError::whole(file, "cannot open the plate description");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw FileError::at_byte(file, e.byte, "not valid JSON");
  } catch (const json::exception& e) {  // a number beyond a double's range (1e400)
    throw FileError::whole(file, std::string("not valid JSON: ") + e.what());
  }
  return plate_from_json(j, file.string());
}

json to_json(const Plate& plate) {
  json corners = json::array();
  for (const Vec3& c : plate.corners) corners.push_back({c.x(), c.y(), c.z()});
  json fiducial = {{"kind", to_string(plate.fiducial.kind)}};
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

std::vector<int> symmetry_shifts(const Plate& plate, double tolerance_mm) {
  const int n = plate.corner_count();
  std::vector<int> shifts;
  std::vector<Vec3> to;
  for (int k = 1; k < n; ++k) {
    to.clear();
    for (int id = 1; id <= n; ++id) to.push_back(plate.corner((id - 1 + k) % n + 1));
    if (fit_rigid(plate.corners, to).rms_mm <= tolerance_mm) shifts.push_back(k);
  }
  return shifts;
}

Eigen::Isometry3d fit_plate_pose(const Plate& plate, std::span<const int> ids, std::span<const Vec3> points_X) {
  std::vector<Vec3> nominal;
  for (int id : ids) nominal.push_back(plate.corner(id));
  return fit_rigid(nominal, points_X).transform;
}

}  // namespace cmm::planner
