// The one sequence of motions a touch is made with (DESIGN.md): from wherever the ball is, rise to
// the clearance plane (a ball on or above it rises no further), travel to above the search start,
// descend to it, search along the approach (the probe's own retract is part of the search), and
// return along the search line to the start, where the next touch's rise leaves from (the cancel
// rule and the recovery of a touch cut short rely on that). The time estimate, the stylus clearance
// check, the DMIS export, the job runner and the preview's dry run all take their motions from here.
#pragma once

#include <string>
#include <vector>

#include "hal/description/machine_description.hpp"
#include "planner/touch.hpp"

namespace cmm::planner {

enum class MotionKind { rise, travel, descend, probe, return_to_start };
const char* to_string(MotionKind kind);  // "rise", "travel", "descend", "probe", "return"

// One command to the machine, M, ball centres of the active tip. A move goes straight from `from`
// to `to`; a probe searches from `from` along `direction` for at most max_travel_mm (a trigger
// before min_travel_mm is refused), then backs off retract_mm — `to` is where that leaves the ball
// after the nominal contact.
struct Motion {
  MotionKind kind = MotionKind::travel;
  Vec3 from = Vec3::Zero(), to = Vec3::Zero();
  double speed_mm_s = 0;
  int touch = -1;     // the touch it belongs to; -1 on the way home
  double time_s = 0;  // trapezoidal, from the machine's speed and acceleration; a probe's to its
                      // nominal contact and back by its retract
  Vec3 direction = Vec3::Zero();  // probe only
  double max_travel_mm = 0, min_travel_mm = 0, retract_mm = 0;
};

// The motions of `touch` with the ball at `from`. A rise, travel or descent of no length is left out;
// the probe and the return are always there (the return's length is the real contact's distance
// from the nominal one, which only the run knows).
std::vector<Motion> touch_motions(const Touch& touch, const Vec3& from, double clearance_z,
                                  const description::MachineDescription& machine);

// From `from` to `home` on the clearance plane: a rise when below it, then the travel.
std::vector<Motion> home_motions(const Vec3& from, const Vec3& home, double clearance_z,
                                 const description::MachineDescription& machine);

// "probe of touch 12 from (x, y, z)": for messages.
std::string describe(const Motion& motion);

}  // namespace cmm::planner
