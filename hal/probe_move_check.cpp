// See probe_move_check.hpp.
#include "hal/probe_move_check.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>

#include "hal/fault.hpp"

namespace cmm::hal {

Vec3 checked_probe_direction(const ProbeMove& p, const description::TravelBox& box) {
  const double length = p.direction.norm();
  if (!p.direction.allFinite() || !(length > 0.5 && length < 2))
    throw std::invalid_argument("probe direction must be a unit vector");
  if (!(p.max_travel_mm > 0) || !(p.min_travel_mm >= 0) || p.min_travel_mm >= p.max_travel_mm)
    throw std::invalid_argument("probe travel must satisfy 0 ≤ min_travel_mm < max_travel_mm");
  const Vec3 d = p.direction / length;
  const Vec3 end = p.start + d * p.max_travel_mm;
  const Vec3 retract = p.start - d * std::max(0.0, p.retract_mm - p.min_travel_mm);
  for (const auto& [point, name] : {std::pair{p.start, "probe start"}, std::pair{end, "probe end"},
                                    std::pair{retract, "probe retract"}})
    if (!box.contains(point)) {
      char text[128];
      std::snprintf(text, sizeof text, "(%.6f,%.6f,%.6f)", point.x(), point.y(), point.z());
      throw SoftLimit(std::string(name) + " " + text + " is outside the travel box");
    }
  return d;
}

}  // namespace cmm::hal
