// Planned motions as commands, and the recovery moves; see touch_motion.hpp.
#include "daemon/touch_motion.hpp"

namespace cmm::daemon {

namespace {
constexpr double same_place_mm = 1e-3;
}

hal::TouchResult run_motion(hal::Cmm& cmm, const planner::Motion& m) {
  if (m.kind == planner::MotionKind::change_tip) {
    cmm.select_tip(m.tip);
    return {};
  }
  if (m.kind != planner::MotionKind::probe) {
    cmm.move({m.to, m.speed_mm_s});
    return {};
  }
  hal::ProbeMove search;
  search.start = m.from;
  search.direction = m.direction;
  search.max_travel_mm = m.max_travel_mm;
  search.speed_mm_s = m.speed_mm_s;
  search.retract_mm = m.retract_mm;
  search.fail_on_miss = false;
  search.min_travel_mm = m.min_travel_mm;
  return cmm.probe(search);
}

hal::TouchResult run_motions(hal::Cmm& cmm, std::span<const planner::Motion> motions,
                           const std::function<void()>& before_motion) {
  hal::TouchResult result;
  for (const planner::Motion& m : motions) {
    if (before_motion) before_motion();
    const hal::TouchResult r = run_motion(cmm, m);
    if (m.kind == planner::MotionKind::probe) result = r;
  }
  return result;
}

std::vector<planner::Motion> motions_from(const hal::Vec3& at, std::span<const planner::Motion> planned,
                                          const planner::Touch& touch, double clearance_z,
                                          const description::MachineDescription& machine) {
  if (!planned.empty() && (planned.front().from - at).norm() <= same_place_mm)
    return {planned.begin(), planned.end()};
  return planner::touch_motions(touch, at, clearance_z, machine);
}

void rise_to_clearance(hal::Cmm& cmm, double clearance_z, const TouchSpeeds& speeds) {
  const hal::Vec3 at = cmm.status().position;
  if (at.z() < clearance_z) cmm.move({hal::Vec3(at.x(), at.y(), clearance_z), speeds.travel_mm_s});
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
