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

ClearanceCheck StylusClearance::check(const Touch& t) const {
  const Vec3 above(t.start.x(), t.start.y(), clearance_z_);
  const Vec3 end = t.start + t.max_travel_mm * t.direction;
  for (const auto& [p, what] : {std::pair{above, "above the approach start"}, {t.start, "the approach start"},
                                {end, "the search end"}})
    if (!machine_.travel_box.contains(p)) return refuse(std::string(what) + " " + describe(p) + " is outside the travel box");
  // Steeply against the stylus the shaft would have to pass through the material being touched.
  if (t.direction.dot(tip_.direction) < -0.5)
    return refuse("the approach points back along the stylus (from below, for a vertical stylus): it cannot reach");
  if (std::min(t.start.z(), end.z()) - radius_ < floor_z_)
    return refuse("the ball would go below the table top at z " + mm(floor_z_));

  // Descent: the ball sweeps the column below the clearance plane. A vertical stylus (head above
  // the ball) stays inside that column, so only the wider head needs its own sweep; any other
  // stylus is checked along the descent, spaced at the shaft radius as along the search.
  const double descent = clearance_z_ - t.start.z();
  if (descent < 0) return refuse("the approach start lies above the clearance plane");
  if (auto hit = obstacles_.first_hit(above, -Vec3::UnitZ(), descent, radius_))
    return refuse("the ball would meet the part at " + describe(hit->contact) + " descending to the approach start");
  const Vec3 up = -tip_.direction;
  if (up.z() > 1 - 1e-9) {
    if (obstacles_.first_hit(above + up * tip_.shaft_length_mm, -Vec3::UnitZ(), descent, tip_.head_radius_mm))
      return refuse("the probe head would meet the part descending to the approach start");
  } else {
    const int steps = std::max(1, static_cast<int>(std::ceil(descent / std::max(tip_.shaft_radius_mm, 0.05))));
    for (int i = 0; i < steps; ++i)  // the start itself is the search's first position, below
      if (auto check = check_stylus_at(above - (descent * i / steps) * Vec3::UnitZ(), "descending to the approach start");
          !check.ok)
        return check;
  }

  // Search: the ball must meet the mesh first near the target, not on something on its way.
  const auto hit = obstacles_.first_hit(t.start, t.direction, t.max_travel_mm, radius_);
  if (!hit) return refuse("the search along the approach never meets the reference mesh");
  const double reach = 2 * delta_ + 0.25;
  if ((hit->contact - t.surface_point).norm() > reach)
    return refuse("the ball would first meet the part at " + describe(hit->contact) + ", " +
                  mm((hit->contact - t.surface_point).norm()) + " from the target");
  // Shaft and head along the search, up to the latest contact the real part allows (δ past the
  // nominal one, plus the sag of the ball's circle across δ); spaced at the shaft radius.
  const double latest = (t.nominal_centre - t.start).norm() + delta_ + radius_ - std::sqrt(std::max(0.0, radius_ * radius_ - delta_ * delta_));
  const int steps = std::max(1, static_cast<int>(std::ceil(latest / std::max(tip_.shaft_radius_mm, 0.05))));
  for (int i = 0; i <= steps; ++i) {
    const Vec3 ball = t.start + (latest * i / steps) * t.direction;
    if (auto check = check_stylus_at(ball, "during the search"); !check.ok) return check;
  }
  return {};
}

}  // namespace cmm::planner
