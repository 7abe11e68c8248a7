// Least-squares planes through measured points, and where two or three planes meet: how a plate corner
// (top face and two side faces) and a chamfer face are computed from touches, with a conditioning check.
#pragma once

#include <span>
#include <stdexcept>

#include "geometry/mesh.hpp"

namespace cmm::planner {

using geometry::Vec3;

// A plate or chamfer face measured badly enough that no plane or corner should be taken from it.
class PlaneFitError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// normal · x = offset, with a unit normal. Whether the normal points out of the material is the
// caller's choice (see oriented_along).
struct Plane {
  Vec3 normal = Vec3::UnitZ();
  double offset = 0;  // mm

  double signed_distance(const Vec3& point) const { return normal.dot(point) - offset; }
};

struct PlaneFit {
  Plane plane;
  Vec3 centroid = Vec3::Zero();
  double rms_mm = 0;      // RMS of the points' distances from the plane
  double max_abs_mm = 0;  // largest distance
  // sqrt(λ_mid / λ_max) of the points' scatter: 0 on a line, 1 for a round patch. Small values mean
  // the plane's tilt about the points' main direction rests on little.
  double spread_ratio = 0;
};

// Total least squares (orthogonal distances). Throws PlaneFitError for fewer than three points,
// non-finite coordinates, or points whose spread_ratio is below `min_spread_ratio` (collinear).
// The normal's sign is unspecified.
PlaneFit fit_plane(std::span<const Vec3> points, double min_spread_ratio = 1e-3);

// The same plane with its normal flipped if needed so that normal · direction ≥ 0.
Plane oriented_along(const Plane& plane, const Vec3& direction);

// |n_a · (n_b × n_c)|: 1 for three mutually square planes, 0 when they share a direction and the
// point is undetermined. The point's error grows like the planes' errors divided by this.
double intersection_conditioning(const Plane& a, const Plane& b, const Plane& c);

// The point common to three planes. Throws PlaneFitError when the conditioning is below
// `min_conditioning`.
Vec3 intersect_planes(const Plane& a, const Plane& b, const Plane& c, double min_conditioning = 1e-3);

struct Line3 {
  Vec3 point = Vec3::Zero();      // the line's point nearest the origin
  Vec3 direction = Vec3::UnitX();  // unit: normalize(n_a × n_b)
};

// The line common to two planes. Throws PlaneFitError when the sine of the angle between their
// normals is below `min_sine`.
Line3 intersect_planes(const Plane& a, const Plane& b, double min_sine = 1e-3);

}  // namespace cmm::planner
