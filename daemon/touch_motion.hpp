// How cmmd drives one planned touch on a machine: up to the clearance plane, across it, down to the
// search start, then the search (DESIGN.md, Safety: travel between touches goes via that plane).
#pragma once

#include <functional>

#include "hal/cmm.hpp"
#include "planner/touch.hpp"

namespace cmm::daemon {

struct TouchSpeeds {
  double travel_mm_s = 0;  // 0: the machine's travel speed
  double probe_mm_s = 5;
};

// Rises from wherever the ball is to clearance_z (a ball above the plane rises no further), travels
// there to above the search start, descends to it, searches, and goes back to the start: the line
// it came down on is the one the plan checked, so the next rise leaves from there. The search
// refuses a trigger in its first millimetre or so (min_travel_mm): the plan starts every search at
// least δ + pre-travel before the nominal contact. `before_motion` runs before each of the motions
// and may throw to end the touch between them: a stop() reaches only a motion that is running.
// Faults propagate as the driver raises them.
hal::TouchResult run_touch(hal::Cmm& cmm, const planner::Touch& touch, double clearance_z, const TouchSpeeds& speeds,
                           const std::function<void()>& before_motion = {});

// Straight up to clearance_z from where the ball is (a ball above the plane stays): the rise every
// touch starts with, safe from where the last touch left the ball (its search start).
void rise_to_clearance(hal::Cmm& cmm, double clearance_z, const TouchSpeeds& speeds);

// After a stop in the middle of a touch: back along the search line to its start, then up to the
// clearance plane, so the ball leaves the way it came in (a straight rise from beside a wall or
// inside a bore could hit what the plan's approach avoided). `before_motion` as for run_touch.
void leave_touch(hal::Cmm& cmm, const hal::Vec3& start, const hal::Vec3& direction, double clearance_z,
                 const TouchSpeeds& speeds, const std::function<void()>& before_motion = {});

}  // namespace cmm::daemon
