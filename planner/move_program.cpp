// Ordering and expanding the touches into motions; see move_program.hpp.
#include "planner/move_program.hpp"

#include "planner/motion_time.hpp"
#include "planner/tour_order.hpp"
#include "planner/travel_bound.hpp"

namespace cmm::planner {

const char* to_string(MotionKind kind) {
  switch (kind) {
    case MotionKind::rise: return "rise";
    case MotionKind::travel: return "travel";
    case MotionKind::descend: return "descend";
    case MotionKind::probe: return "probe";
    case MotionKind::retract: return "retract";
  }
  return "?";
}

MoveProgram build_program(std::vector<Touch> touches, const description::MachineDescription& machine, const Vec3& home,
                          double clearance_z) {
  MoveProgram program;
  program.home = home;
  program.clearance_z = clearance_z;
  const TravelCost cost{machine.max_speed_mm_s, machine.max_accel_mm_s2};
  std::vector<Eigen::Vector2d> stops;
  stops.reserve(touches.size());
  for (const Touch& t : touches) stops.push_back(t.start.head<2>());
  const Eigen::Vector2d home_xy = home.head<2>();
  const std::vector<int> order = order_touches(stops, home_xy, cost);
  program.touches.reserve(touches.size());
  for (int i : order) program.touches.push_back(std::move(touches[static_cast<std::size_t>(i)]));

  auto add = [&](MotionKind kind, const Vec3& from, const Vec3& to, double speed, int touch) {
    const double time = trapezoid_time((to - from).norm(), speed, machine.max_accel_mm_s2);
    program.motions.push_back({kind, from, to, speed, touch, time});
    program.time_s += time;
    return time;
  };
  // Fixed per-touch costs: descent, search to the nominal contact, retract, rise back.
  double fixed = 0;
  Vec3 at = home;
  for (const Touch& t : program.touches) {
    const Vec3 above(t.start.x(), t.start.y(), clearance_z);
    if (at.z() < clearance_z) fixed += add(MotionKind::rise, at, Vec3(at.x(), at.y(), clearance_z), machine.max_speed_mm_s, t.id);
    at = Vec3(at.x(), at.y(), clearance_z);
    add(MotionKind::travel, at, above, machine.max_speed_mm_s, t.id);
    fixed += add(MotionKind::descend, above, t.start, machine.max_speed_mm_s, t.id);
    const Vec3 contact = t.nominal_centre;
    fixed += add(MotionKind::probe, t.start, contact, machine.probe_speed_mm_s, t.id);
    fixed += add(MotionKind::retract, contact, t.start, machine.max_speed_mm_s, t.id);
    at = t.start;
  }
  if (at.z() < clearance_z) fixed += add(MotionKind::rise, at, Vec3(at.x(), at.y(), clearance_z), machine.max_speed_mm_s, -1);
  at.z() = clearance_z;
  if ((at - home).norm() > 0) add(MotionKind::travel, at, home, machine.max_speed_mm_s, -1);
  program.lower_bound_s = fixed + travel_lower_bound(stops, home_xy, cost);
  return program;
}

}  // namespace cmm::planner
