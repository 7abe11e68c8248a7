// Names of hole sources as they appear in the plan JSON, and aligning rim points to their hole.
#include "geometry/hole.hpp"

namespace cmm::geometry {

const char* to_string(HoleSource source) {
  return source == HoleSource::bore ? "bore" : "open_boundary";
}

void align_to_hole(EdgePoint& p, const Hole& hole) {
  const Vec3 offset = p.position - hole.centre;
  const Vec3 radial = offset - offset.dot(hole.axis) * hole.axis;
  if (!p.n_down || radial.norm() < 0.5 * hole.radius) return;
  Vec3 tangent = hole.axis.cross(radial).normalized();
  if (tangent.dot(p.tangent) < 0) tangent = -tangent;
  const Vec3 up = p.n_up - p.n_up.dot(tangent) * tangent, down = *p.n_down - p.n_down->dot(tangent) * tangent;
  if (up.norm() < 0.5 || down.norm() < 0.5) return;  // a normal along the rim: leave the point as found
  p.n_up = up.normalized(), p.n_down = down.normalized();
  const Vec3 cross = p.n_up.cross(*p.n_down);
  if (cross.norm() > 1e-9) p.tangent = cross.normalized();
}

}  // namespace cmm::geometry
