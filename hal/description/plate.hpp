// The base plate the part sits on (plate.json): nominal corners in the plate's own frame P, its
// thickness and the one asymmetric fiducial that tells corner 1 from the others; and the geometric
// questions about the nominal plate that registration, corner probing and the simulator ask.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace cmm::description {

using Vec3 = Eigen::Vector3d;

// A rectangular plate's corners shifted cyclically by two agree on every length, so lengths cannot
// settle the corner order; the fiducial can, because it sits at (or near) one corner only.
struct PlateFiducial {
  enum class Kind { chamfer, hole };
  Kind kind = Kind::chamfer;
  // chamfer: a vertical cut through the whole thickness across corner `corner`, from the point
  // size_mm along one edge to the point size_mm along the other.
  int corner = 1;
  double size_mm = 5;
  // hole: a vertical hole with its axis at (centre, z) in P, from the top down depth_mm (a through
  // hole when depth_mm equals the thickness).
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double diameter_mm = 6;
  double depth_mm = 0;  // 0 in a file means through
};

const char* to_string(PlateFiducial::Kind kind);

// Plate frame P: +z out of the top face, the top face at z = corners' z, the bottom at z − thickness.
// Corner ids are 1-based positions in `corners`, counter-clockwise seen from +z (the handedness the
// registration checks the measured order against).
struct Plate {
  std::string name;
  std::vector<Vec3> corners;  // nominal, P, mm; all with the same z (the top face)
  double thickness_mm = 10;
  PlateFiducial fiducial;

  int corner_count() const { return static_cast<int>(corners.size()); }
  const Vec3& corner(int id) const { return corners.at(static_cast<std::size_t>(id - 1)); }
  double top_z() const { return corners.empty() ? 0.0 : corners.front().z(); }
  int next(int id) const { return id % corner_count() + 1; }
  int previous(int id) const { return (id + corner_count() - 2) % corner_count() + 1; }
  bool adjacent(int a, int b) const { return next(a) == b || next(b) == a; }
};

// Parses and checks a plate: at least three corners, finite, one top height, strictly convex and
// counter-clockwise seen from +z, a positive thickness, and a fiducial that fits on the plate and
// breaks its symmetry. FieldError names the source and each bad field by its pointer.
Plate plate_from_json(const nlohmann::json& j, const std::string& source = "<json>");
Plate read_plate(const std::filesystem::path& file);
nlohmann::json to_json(const Plate& plate);

// config/plate.json, compiled in: the plate cmmd registers by and the simulator stands the part on
// unless told otherwise.
Plate default_plate();

// Unit outward normal (P) of the side face from corner `id` to corner next(id).
Vec3 side_normal(const Plate& plate, int id);

// The fiducial as geometry in P.
struct FiducialGeometry {
  Vec3 point = Vec3::Zero();   // nominal fiducial point: chamfer face centre / hole axis, both at mid-thickness
  Vec3 normal = Vec3::Zero();  // chamfer: unit outward normal of the face; hole: the axis (+z)
  Vec3 along = Vec3::Zero();   // chamfer: unit horizontal direction across the face; hole: zero
  double half_width_mm = 0;    // chamfer: half the face's width; hole: the radius
  double bottom_z = 0;         // lowest z of the face or hole wall (P)
};
FiducialGeometry fiducial_geometry(const Plate& plate);

// How far a measured fiducial point (expressed in P) is from the nominal fiducial: a chamfer point
// should lie on the chamfer face, a hole point on the hole's axis, within the plate's thickness.
struct FiducialDeviation {
  double off_mm = 0;      // chamfer: distance from the face's plane; hole: distance from the axis
  double outside_mm = 0;  // how far beyond the face's edges / the wall's depth range (0 inside)
};
FiducialDeviation fiducial_deviation(const Plate& plate, const Vec3& point_P);

// Cyclic shifts k (1 … N−1) that map the nominal corners onto themselves by a rigid motion
// (corner i onto corner i+k): {2} for a rectangle, {1, 2, 3} for a square, {} for a general quad.
std::vector<int> symmetry_shifts(const Plate& plate, double tolerance_mm = 1e-6);

}  // namespace cmm::description
