#include "daemon/touch_motion.hpp"

#include <algorithm>

namespace cmm::daemon {

void rise_to_clearance(hal::Cmm& cmm, double clearance_z, const TouchSpeeds& speeds) {
  const hal::Vec3 at = cmm.status().position;
  if (at.z() < clearance_z) cmm.move({hal::Vec3(at.x(), at.y(), clearance_z), speeds.travel_mm_s});
}

hal::TouchResult run_touch(hal::Cmm& cmm, const planner::Touch& touch, double clearance_z, const TouchSpeeds& speeds,
                           const std::function<void()>& before_motion) {
  const auto check = [&] {
    if (before_motion) before_motion();
  };
  check();
  rise_to_clearance(cmm, clearance_z, speeds);
  check();
  const hal::Vec3 above(touch.start.x(), touch.start.y(), std::max(clearance_z, cmm.status().position.z()));
  cmm.move({above, speeds.travel_mm_s});
  check();
  cmm.move({touch.start, speeds.travel_mm_s});
  check();
  hal::ProbeMove search;
  search.start = touch.start;
  search.direction = touch.direction;
  search.max_travel_mm = touch.max_travel_mm;
  search.speed_mm_s = speeds.probe_mm_s;
  search.retract_mm = touch.retract_mm;
  search.fail_on_miss = false;  // a miss is a result for this point, not a reason to stop the job
  // Refuse a trigger in the first fifth of the run-up: the part is then far from where the plan put it.
  search.min_travel_mm = std::min(0.2 * touch.max_travel_mm, 0.5);
  const hal::TouchResult result = cmm.probe(search);
  cmm.move({touch.start, speeds.travel_mm_s});
  return result;
}

void leave_touch(hal::Cmm& cmm, const hal::Vec3& start, const hal::Vec3& direction, double clearance_z,
                 const TouchSpeeds& speeds, const std::function<void()>& before_motion) {
  const hal::Vec3 at = cmm.status().position;
  const hal::Vec3 from_start = at - start;
  const double along = from_start.dot(direction);
  // Only when the ball is on the search line (stopped mid-search, or after its retract).
  if ((from_start - along * direction).norm() < 1e-3 && along > 1e-6) {
    if (before_motion) before_motion();
    cmm.move({start, speeds.probe_mm_s});
  }
  if (before_motion) before_motion();
  rise_to_clearance(cmm, clearance_z, speeds);
}

}  // namespace cmm::daemon
