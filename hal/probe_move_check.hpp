// The checks a driver makes on a ProbeMove before anything moves, when the machine itself cannot
// (Grbl, I++ DME): a unit direction, a sane travel, and start, end and retract inside the travel box.
#pragma once

#include "hal/description/machine_description.hpp"
#include "hal/motion.hpp"

namespace cmm::hal {

// The search's unit direction. Throws std::invalid_argument for a direction that is not a unit
// vector or a travel outside 0 ≤ min_travel_mm < max_travel_mm, and SoftLimit naming the point
// (start, end or retract) that lies outside `box`.
Vec3 checked_probe_direction(const ProbeMove& move, const description::TravelBox& box);

}  // namespace cmm::hal
