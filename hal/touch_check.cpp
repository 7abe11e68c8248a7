// See touch_check.hpp.
#include "hal/touch_check.hpp"

#include <cstdio>

#include "hal/fault.hpp"

namespace cmm::hal {

namespace {

[[noreturn]] void refuse(const std::string& machine, const Vec3& centre, const char* why, double by_mm) {
  char text[256];
  std::snprintf(text, sizeof text, "reported a touch at (%.6f, %.6f, %.6f) %s by %.6f mm: refused, not a contact",
                centre.x(), centre.y(), centre.z(), why, by_mm);
  throw Protocol(machine + " " + text);
}

}  // namespace

TouchResult checked_touch(const ProbeMove& move, const TouchResult& touch, const std::string& machine) {
  if (!touch.contact) return touch;
  if (!touch.centre.allFinite()) throw Protocol(machine + " reported a touch whose centre is not a number: refused");
  const Vec3 d = move.direction.normalized();
  const Vec3 offset = touch.centre - move.start;
  const double along = offset.dot(d);
  const double sideways = (offset - along * d).norm();
  if (sideways > kTouchLateralToleranceMm) refuse(machine, touch.centre, "off the commanded search line", sideways);
  if (along < -kTouchAlongToleranceMm) refuse(machine, touch.centre, "before the search's start", -along);
  if (along > move.max_travel_mm + kTouchAlongToleranceMm)
    refuse(machine, touch.centre, "past the search's end", along - move.max_travel_mm);
  return touch;
}

}  // namespace cmm::hal
