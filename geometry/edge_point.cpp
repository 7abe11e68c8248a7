// The n_up convention and kind names, kept next to the type they define.
#include "geometry/edge_point.hpp"

#include <cmath>

namespace cmm::geometry {

const char* to_string(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::sharp_edge: return "sharp_edge";
    case EdgeKind::hole_rim: return "hole_rim";
    case EdgeKind::boundary: return "boundary";
  }
  return "?";
}

bool is_up_side(const Vec3& a, const Vec3& b) {
  // Components closer than ~3° count as equal and fall through to the next axis: on a vertical
  // edge the z components differ only by noise, and the choice must not flip from point to point.
  constexpr double tie = 0.05;
  for (int axis : {2, 1, 0})
    if (std::abs(a(axis) - b(axis)) > tie) return a(axis) > b(axis);
  return true;
}

}  // namespace cmm::geometry
