// Ordering the touches and expanding them into motions; see move_program.hpp.
#include "planner/move_program.hpp"

#include <algorithm>
#include <string>

#include "planner/motion_time.hpp"
#include "planner/tour_order.hpp"
#include "planner/travel_bound.hpp"

namespace cmm::planner {

namespace {

// Touches of one feature: the same edge point (its two window touches, or its face touches), the
// same bore, the same plate corner.
bool same_feature(const Touch& a, const Touch& b) {
  const auto group = [](TouchTarget t) { return t == TouchTarget::face ? TouchTarget::edge : t; };
  return group(a.target) == group(b.target) && a.edge_point == b.edge_point && a.hole == b.hole && a.corner == b.corner;
}

// Orders one tip's touches from `from` (xy), appending them to `ordered`.
void order_group_of_tip(std::vector<Touch> touches, const Eigen::Vector2d& from, const TravelCost& cost,
                        std::vector<Touch>& ordered) {
  if (touches.empty()) return;
  // Groups of consecutive touches of one feature, each visited as one stop at its first touch.
  std::vector<std::pair<std::size_t, std::size_t>> groups;  // [begin, end) in `touches`
  for (std::size_t i = 0; i < touches.size(); ++i)
    if (i == 0 || !same_feature(touches[i - 1], touches[i])) groups.emplace_back(i, i + 1);
    else groups.back().second = i + 1;
  std::vector<Eigen::Vector2d> stops;
  for (const auto& [begin, end] : groups) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (std::size_t i = begin; i < end; ++i) mean += touches[i].start.head<2>();
    stops.push_back(mean / static_cast<double>(end - begin));
  }
  // Each group is entered at whichever of its ends is nearer to where the ball comes from: the two
  // touches of an edge point lie a few millimetres apart across the edge, and taking every pair the
  // same way round would cross the edge twice per point.
  Eigen::Vector2d at = from;
  for (const int g : order_touches(stops, from, cost)) {
    const auto [begin, end] = groups[static_cast<std::size_t>(g)];
    const bool reverse = cost(at, touches[end - 1].start.head<2>()) < cost(at, touches[begin].start.head<2>());
    for (std::size_t k = 0; k < end - begin; ++k) ordered.push_back(std::move(touches[reverse ? end - 1 - k : begin + k]));
    at = ordered.back().start.head<2>();
  }
}

}  // namespace

MoveProgram build_program(std::vector<Touch> touches, const description::MachineDescription& machine, const Vec3& home,
                          double clearance_z) {
  const TravelCost cost{machine.max_speed_mm_s, machine.max_accel_mm_s2};
  // One tip after the other, the active one first: every change costs a changer's cycle (or the
  // operator's hands), so each tip is changed to once.
  std::vector<std::string> tips{machine.active_tip};
  for (const Touch& t : touches)
    if (!t.tip.empty() && std::find(tips.begin(), tips.end(), t.tip) == tips.end()) tips.push_back(t.tip);
  std::vector<Touch> ordered;
  ordered.reserve(touches.size());
  for (const std::string& tip : tips) {
    std::vector<Touch> group;
    for (Touch& t : touches)
      if (t.tip == tip || (t.tip.empty() && tip == machine.active_tip)) group.push_back(std::move(t));
    order_group_of_tip(std::move(group), ordered.empty() ? Eigen::Vector2d(home.head<2>()) : Eigen::Vector2d(ordered.back().start.head<2>()),
                       cost, ordered);
  }
  return program_in_order(std::move(ordered), machine, home, clearance_z);
}

MoveProgram program_in_order(std::vector<Touch> touches, const description::MachineDescription& machine,
                             const Vec3& home, double clearance_z) {
  MoveProgram program;
  program.home = home;
  program.clearance_z = clearance_z;
  program.touches = std::move(touches);
  Vec3 at = home;
  description::MachineDescription now = machine;  // its active tip changes with the program
  for (const Touch& t : program.touches) {
    for (Motion& m : tip_change_motions(at, t.tip, clearance_z, now)) {
      at = m.to;
      if (m.kind == MotionKind::change_tip) now.active_tip = m.tip;
      program.motions.push_back(std::move(m));
    }
    for (Motion& m : touch_motions(t, at, clearance_z, now)) program.motions.push_back(std::move(m));
    at = t.start;
  }
  for (Motion& m : home_motions(at, home, clearance_z, now)) program.motions.push_back(std::move(m));

  // Every touch's start is descended to once and risen from once, whatever the order; only the
  // travel between them depends on it, and no order travels less than a spanning tree of the touches.
  double fixed = 0;
  for (const Motion& m : program.motions) {
    program.time_s += m.time_s;
    if (m.kind != MotionKind::travel) fixed += m.time_s;
  }
  std::vector<Eigen::Vector2d> points;
  for (const Touch& t : program.touches) points.push_back(t.start.head<2>());
  program.lower_bound_s =
      fixed + travel_lower_bound(points, home.head<2>(), {machine.max_speed_mm_s, machine.max_accel_mm_s2});
  return program;
}

std::span<const Motion> motions_of(const MoveProgram& program, int touch_id) {
  const auto same = [touch_id](const Motion& m) { return m.touch == touch_id; };
  const auto first = std::find_if(program.motions.begin(), program.motions.end(), same);
  const auto last = std::find_if_not(first, program.motions.end(), same);
  return {first, last};
}

std::span<const Motion> home_motions_of(const MoveProgram& program) {
  auto first = program.motions.end();
  while (first != program.motions.begin() && std::prev(first)->touch == -1) --first;
  return {first, program.motions.end()};
}

}  // namespace cmm::planner
