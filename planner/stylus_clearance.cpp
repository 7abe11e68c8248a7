// Safety checks of one touch's motions; see stylus_clearance.hpp.
#include "planner/stylus_clearance.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace cmm::planner {

namespace {

std::string describe(const Vec3& p) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(3);
  out << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return out.str();
}

std::string mm(double value) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(3);
  out << value << " mm";
  return out.str();
}

ClearanceCheck refuse(std::string reason) { return {false, std::move(reason)}; }

}  // namespace

StylusClearance::StylusClearance(const geometry::BallSweeper& obstacles, double floor_z,
                                 const description::MachineDescription& machine, double ball_radius, double clearance_z,
                                 double delta)
    : obstacles_(obstacles),
      floor_z_(floor_z),
      machine_(machine),
      tip_(machine.tip()),
      radius_(ball_radius),
      clearance_z_(clearance_z),
      delta_(delta) {}

ClearanceCheck StylusClearance::check_stylus_at(const Vec3& ball, const char* where) const {
  // The shaft, from the top of the ball to the head, as segment distance: a cylinder of the
  // shaft's radius is clear when its axis keeps that radius from the mesh.
  const Vec3 up = -tip_.direction;
  const Vec3 shaft_bottom = ball + up * radius_, head = ball + up * tip_.shaft_length_mm;
  if (obstacles_.closest_to_segment(shaft_bottom, head, tip_.shaft_radius_mm).face >= 0)
    return refuse(std::string("the stylus shaft would meet the part ") + where);
  if (obstacles_.closest_to_point(head, tip_.head_radius_mm).face >= 0)
    return refuse(std::string("the probe head would meet the part ") + where);
  if (std::min(shaft_bottom.z(), head.z()) - tip_.shaft_radius_mm < floor_z_ ||
      head.z() - tip_.head_radius_mm < floor_z_)
    return refuse(std::string("the stylus would go below the table ") + where);
  return {};
}

ClearanceCheck StylusClearance::check_in_box(const Vec3& p, const char* what) const {
  if (!machine_.travel_box.contains(p)) return refuse(std::string(what) + " " + describe(p) + " is outside the travel box");
  return {};
}

// The ball sweeps the column below the clearance plane. A vertical stylus (head above the ball)
// stays inside that column, so only the wider head needs its own sweep; any other stylus is checked
// along the descent, spaced at the shaft radius as along the search.
ClearanceCheck StylusClearance::check_descent(const Motion& m) const {
  if (auto c = check_in_box(m.from, "above the approach start"); !c.ok) return c;
  if (auto c = check_in_box(m.to, "the approach start"); !c.ok) return c;
  const double descent = m.from.z() - m.to.z();
  if (descent < 0) return refuse("the approach start lies above the clearance plane");
  if (m.to.z() - radius_ < floor_z_) return refuse("the ball would go below the table top at z " + mm(floor_z_));
  if (auto hit = obstacles_.first_hit(m.from, -Vec3::UnitZ(), descent, radius_))
    return refuse("the ball would meet the part at " + describe(hit->contact) + " descending to the approach start");
  const Vec3 up = -tip_.direction;
  if (up.z() > 1 - 1e-9) {
    if (obstacles_.first_hit(m.from + up * tip_.shaft_length_mm, -Vec3::UnitZ(), descent, tip_.head_radius_mm))
      return refuse("the probe head would meet the part descending to the approach start");
    return {};
  }
  const int steps = std::max(1, static_cast<int>(std::ceil(descent / std::max(tip_.shaft_radius_mm, 0.05))));
  for (int i = 0; i < steps; ++i)  // the start itself is the search's first position, checked with it
    if (auto c = check_stylus_at(m.from - (descent * i / steps) * Vec3::UnitZ(), "descending to the approach start");
        !c.ok)
      return c;
  return {};
}

// The search and the probe's retract: the ball must first meet the mesh near the target, and the
// stylus clear the part up to the latest contact the real part allows; the retract from the earliest
// contact may take the ball back past the start, along the same line.
ClearanceCheck StylusClearance::check_search(const Touch& t, const Motion& m) const {
  const Vec3& d = m.direction;
  const Vec3 end = m.from + m.max_travel_mm * d;
  if (auto c = check_in_box(end, "the search end"); !c.ok) return c;
  // As the machine checks a search before it starts: the farthest a retract can reach back.
  const Vec3 retract_reach = m.from - std::max(0.0, m.retract_mm - m.min_travel_mm) * d;
  if (auto c = check_in_box(retract_reach, "the probe's retract"); !c.ok) return c;
  if (std::min(m.from.z(), end.z()) - radius_ < floor_z_)
    return refuse("the ball would go below the table top at z " + mm(floor_z_));

  const auto hit = obstacles_.first_hit(m.from, d, m.max_travel_mm, radius_);
  if (!hit) return refuse("the search along the approach never meets the reference mesh");
  const double reach = 2 * delta_ + 0.25;
  if ((hit->contact - t.surface_point).norm() > reach)
    return refuse("the ball would first meet the part at " + describe(hit->contact) + ", " +
                  mm((hit->contact - t.surface_point).norm()) + " from the target");
  // Shaft and head along the search, up to the latest contact the real part allows (δ past the
  // nominal one, plus the sag of the ball's circle across δ); spaced at the shaft radius.
  const double nominal = (t.nominal_centre - m.from).norm();
  const double latest = nominal + delta_ + radius_ - std::sqrt(std::max(0.0, radius_ * radius_ - delta_ * delta_));
  const int steps = std::max(1, static_cast<int>(std::ceil(latest / std::max(tip_.shaft_radius_mm, 0.05))));
  for (int i = 0; i <= steps; ++i) {
    const Vec3 ball = m.from + (latest * i / steps) * d;
    if (auto c = check_stylus_at(ball, "during the search"); !c.ok) return c;
  }
  // From a contact δ early, the retract ends behind the start.
  const double behind = m.retract_mm - std::max(0.0, nominal - delta_);
  if (behind > 0) {
    const Vec3 ball = m.from - behind * d;
    if (ball.z() - radius_ < floor_z_) return refuse("the ball would go below the table top at z " + mm(floor_z_) + " retracting");
    if (obstacles_.first_hit(m.from, -d, behind, radius_)) return refuse("the ball would meet the part retracting behind the start");
    if (auto c = check_stylus_at(ball, "retracting behind the search start"); !c.ok) return c;
  }
  return {};
}

ClearanceCheck StylusClearance::check(const Touch& t) const {
  // Steeply against the stylus the shaft would have to pass through the material being touched.
  if (t.direction.dot(tip_.direction) < -0.5)
    return refuse("the approach points back along the stylus (from below, for a vertical stylus): it cannot reach");
  // The touch's own motions, from above its start: the rise that brings the ball there is the touch
  // before's descent backwards, checked with that one, and the travel runs on the clearance plane.
  const Vec3 above(t.start.x(), t.start.y(), clearance_z_);
  if (auto c = check_in_box(above, "above the approach start"); !c.ok) return c;
  for (const Motion& m : touch_motions(t, above, clearance_z_, machine_)) {
    ClearanceCheck c;
    switch (m.kind) {
      case MotionKind::rise:
      case MotionKind::travel: c = check_in_box(m.to, "the travel's end"); break;
      case MotionKind::descend: c = check_descent(m); break;
      case MotionKind::probe: c = check_search(t, m); break;
      case MotionKind::return_to_start: c = check_in_box(m.to, "the approach start"); break;  // on the searched line
      case MotionKind::change_tip: break;  // never part of a touch's own motions
    }
    if (!c.ok) return c;
  }
  return {};
}

}  // namespace cmm::planner
