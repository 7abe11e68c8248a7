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

enum class MotionKind { rise, travel, descend, probe, return_to_start, change_tip };
const char* to_string(MotionKind kind);  // "rise", "travel", "descend", "probe", "return", "change_tip"

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
  std::string tip;  // change_tip only: the tip made active; `to` is its ball centre where `from` was the old one's
};

// What one tip change costs in the estimate: an automatic changer's cycle to its rack and back (ten to
// twenty seconds on a bridge CMM); a change by hand takes what the operator takes.
constexpr double tip_change_s = 15;

// The motions of `touch` with the ball at `from`. A rise, travel or descent of no length is left out;
// the probe and the return are always there (the return's length is the real contact's distance
// from the nominal one, which only the run knows).
std::vector<Motion> touch_motions(const Touch& touch, const Vec3& from, double clearance_z,
                                  const description::MachineDescription& machine);

// From `from` to `home` on the clearance plane: a rise when below it, then the travel.
std::vector<Motion> home_motions(const Vec3& from, const Vec3& home, double clearance_z,
                                 const description::MachineDescription& machine);

// Where the active tip's ball must be for a change to `tip`: high enough that the new tip's ball, lower
// by the difference of their offsets (a longer stylus), is on or above the clearance plane.
double tip_change_z(const description::MachineDescription& machine, const std::string& tip, double clearance_z);

// From `from`, with `machine`'s active tip, to `tip`: a rise to tip_change_z when below it (a
// changer's rack and a hand both need the probe clear of the part), then the change, after which the
// ball centre is where the new tip's offset puts it. Nothing when `tip` is active already.
std::vector<Motion> tip_change_motions(const Vec3& from, const std::string& tip, double clearance_z,
                                       const description::MachineDescription& machine);

// "probe of touch 12 from (x, y, z)": for messages.
std::string describe(const Motion& motion);

}  // namespace cmm::planner
