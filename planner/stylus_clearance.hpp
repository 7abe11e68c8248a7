// Whether one touch's motions are safe: inside the travel box, above the table, and with the ball,
// shaft and head clear of the reference mesh from the clearance plane down to the contact and back.
#pragma once

#include <string>

#include "geometry/ball_sweep.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/touch.hpp"
#include "planner/touch_sequence.hpp"

namespace cmm::planner {

struct ClearanceCheck {
  bool ok = true;
  std::string reason;  // the first motion that failed, and what it met
};

class StylusClearance {
 public:
  // `obstacles` is the reference mesh in M; nothing of the stylus may go below `floor_z` (the
  // table or base-plate top). `delta` bounds how far the real surface may be from the mesh.
  StylusClearance(const geometry::BallSweeper& obstacles, double floor_z, const description::MachineDescription& machine,
                  double ball_radius, double clearance_z, double delta);

  // The touch's motions (planner/touch_sequence): the descent from the clearance plane to the start,
  // the search to the latest possible contact, the probe's retract from the earliest one, the return
  // (on the searched line) and, backwards, the rise. The ball must first meet the mesh near the target.
  ClearanceCheck check(const Touch& touch) const;

  double clearance_z() const { return clearance_z_; }

 private:
  ClearanceCheck check_stylus_at(const Vec3& ball_centre, const char* where) const;
  ClearanceCheck check_in_box(const Vec3& p, const char* what) const;
  ClearanceCheck check_descent(const Motion& descend) const;
  ClearanceCheck check_search(const Touch& touch, const Motion& probe) const;

  const geometry::BallSweeper& obstacles_;
  double floor_z_;
  const description::MachineDescription& machine_;
  description::StylusTip tip_;
  double radius_, clearance_z_, delta_;
};

}  // namespace cmm::planner
