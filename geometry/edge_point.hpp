// A reference edge point (thesis §5.1 Sedge): where the scan puts a feature the probe must re-measure,
// with the outward normals of its two sides; the fields are those of the plan JSON in DESIGN.md.
#pragma once

#include <algorithm>
#include <optional>
#include <string>

#include "geometry/mesh.hpp"

namespace cmm::geometry {

enum class EdgeKind { sharp_edge, hole_rim, boundary };

const char* to_string(EdgeKind kind);

struct EdgePoint {
  int id = 0;
  EdgeKind kind = EdgeKind::sharp_edge;
  bool convex = true;
  Vec3 position = Vec3::Zero();
  // n_up is the side whose normal has the larger +z (then +y, then +x) component; an open boundary
  // has only one side, and no n_down.
  Vec3 n_up = Vec3::UnitZ();
  std::optional<Vec3> n_down;
  Vec3 tangent = Vec3::UnitX();  // normalize(n_up × n_down); along the boundary where there is no n_down
  bool normals_inferred = false;  // n_down is not measured but inferred (hole rim whose wall the scan lost)
  std::optional<double> interior_angle_rad;  // material angle between the two sides
  // Standard error of each normal's turn about the edge: the one component that moves a window.
  double n_up_uncertainty_rad = 0, n_down_uncertainty_rad = 0;
  double n_up_spread_rad = 0, n_down_spread_rad = 0;
  // How far the mesh's crease may lie from the true edge here on its own (a coarse fan's chord is
  // inside the circle): added to the plan's δ for this point.
  double mesh_deviation_mm = 0;
  // Standard error of `position` from the mesh's vertex noise, after the crease's smoothing: a point on a
  // short closed curve or at an open curve's end is smoothed less. Its δ is at least 3 of these.
  double position_sigma_mm = 0;
  bool probeable = true;
  std::string reason;  // why not probeable
  int curve = -1;      // feature curve or boundary loop it was sampled on
  int hole = -1;       // hole id for rim points
};

// Orders two side normals by the n_up convention; true when `a` is the up side.
bool is_up_side(const Vec3& a, const Vec3& b);

// The δ a point's window and search are made for: the plan's, or 3 standard errors of the point's own
// position where that is more, and the mesh's own distance from the edge on top.
inline double delta_at(const EdgePoint& p, double plan_delta) {
  return std::max(plan_delta, 3 * p.position_sigma_mm) + p.mesh_deviation_mm;
}

}  // namespace cmm::geometry
