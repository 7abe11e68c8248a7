// The touch sequence; see touch_sequence.hpp.
#include "planner/touch_sequence.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "planner/motion_time.hpp"

namespace cmm::planner {

namespace {

Motion move(MotionKind kind, const Vec3& from, const Vec3& to, int touch, const description::MachineDescription& m) {
  Motion motion;
  motion.kind = kind;
  motion.from = from;
  motion.to = to;
  motion.speed_mm_s = m.max_speed_mm_s;
  motion.touch = touch;
  motion.time_s = trapezoid_time((to - from).norm(), m.max_speed_mm_s, m.max_accel_mm_s2);
  return motion;
}

void add_move(std::vector<Motion>& out, MotionKind kind, const Vec3& from, const Vec3& to, int touch,
              const description::MachineDescription& m) {
  if ((to - from).norm() > 0) out.push_back(move(kind, from, to, touch, m));
}

// Up to the plane when below it, across to `target` on it.
Vec3 via_clearance(std::vector<Motion>& out, const Vec3& from, const Vec3& target_xy, double clearance_z, int touch,
                   const description::MachineDescription& m) {
  Vec3 at = from;
  if (at.z() < clearance_z) {
    const Vec3 up(at.x(), at.y(), clearance_z);
    add_move(out, MotionKind::rise, at, up, touch, m);
    at = up;
  }
  const Vec3 above(target_xy.x(), target_xy.y(), clearance_z);
  add_move(out, MotionKind::travel, at, above, touch, m);
  return above;
}

}  // namespace

const char* to_string(MotionKind kind) {
  switch (kind) {
    case MotionKind::rise: return "rise";
    case MotionKind::travel: return "travel";
    case MotionKind::descend: return "descend";
    case MotionKind::probe: return "probe";
    case MotionKind::return_to_start: return "return";
    case MotionKind::change_tip: return "change_tip";
  }
  return "?";
}

std::vector<Motion> touch_motions(const Touch& t, const Vec3& from, double clearance_z,
                                  const description::MachineDescription& m) {
  std::vector<Motion> out;
  const Vec3 above = via_clearance(out, from, t.start, clearance_z, t.id, m);
  add_move(out, MotionKind::descend, above, t.start, t.id, m);

  Motion probe;
  probe.kind = MotionKind::probe;
  probe.touch = t.id;
  probe.from = t.start;
  probe.direction = t.direction;
  probe.max_travel_mm = t.max_travel_mm;
  probe.min_travel_mm = t.min_travel_mm;
  probe.retract_mm = t.retract_mm;
  probe.speed_mm_s = m.probe_speed_mm_s;
  probe.to = t.nominal_centre - t.retract_mm * t.direction;
  // The search at probing speed to the nominal contact, then the retract at travel speed.
  probe.time_s = trapezoid_time((t.nominal_centre - t.start).norm(), m.probe_speed_mm_s, m.max_accel_mm_s2) +
                 trapezoid_time(t.retract_mm, m.max_speed_mm_s, m.max_accel_mm_s2);
  out.push_back(probe);
  out.push_back(move(MotionKind::return_to_start, probe.to, t.start, t.id, m));
  return out;
}

std::vector<Motion> home_motions(const Vec3& from, const Vec3& home, double clearance_z,
                                 const description::MachineDescription& m) {
  std::vector<Motion> out;
  via_clearance(out, from, home, clearance_z, -1, m);
  return out;
}

double tip_change_z(const description::MachineDescription& machine, const std::string& tip, double clearance_z) {
  const description::StylusTip* next = machine.find_tip(tip);
  if (next == nullptr) throw std::invalid_argument("the machine has no tip \"" + tip + "\" to change to");
  const double z = clearance_z + std::max(0.0, machine.tip().offset.z() - next->offset.z());
  if (z > machine.travel_box.max.z())
    throw std::invalid_argument("a change to tip " + tip + " needs the ball at z " + std::to_string(z) +
                                " mm, above the travel box: its stylus is too long for this clearance plane");
  return z;
}

std::vector<Motion> tip_change_motions(const Vec3& from, const std::string& tip, double clearance_z,
                                       const description::MachineDescription& machine) {
  std::vector<Motion> out;
  if (tip.empty() || tip == machine.active_tip) return out;
  const description::StylusTip* next = machine.find_tip(tip);
  const double change_z = tip_change_z(machine, tip, clearance_z);
  Vec3 at = from;
  if (at.z() < change_z) {
    const Vec3 up(at.x(), at.y(), change_z);
    add_move(out, MotionKind::rise, at, up, -1, machine);
    at = up;
  }
  Motion change;
  change.kind = MotionKind::change_tip;
  change.from = at;
  change.to = at + (next->offset - machine.tip().offset);
  change.tip = tip;
  change.speed_mm_s = machine.max_speed_mm_s;
  change.time_s = tip_change_s;
  out.push_back(change);
  return out;
}

std::string describe(const Motion& motion) {
  if (motion.kind == MotionKind::change_tip) return "change to tip " + motion.tip;
  char text[160];
  std::snprintf(text, sizeof text, "%s of touch %d from (%.4f, %.4f, %.4f)", to_string(motion.kind), motion.touch,
                motion.from.x(), motion.from.y(), motion.from.z());
  return text;
}

}  // namespace cmm::planner
