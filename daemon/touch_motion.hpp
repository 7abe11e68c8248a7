// How cmmd drives planned motions (planner/touch_sequence.hpp) on a machine, one command each, and
// the recovery moves that stay outside any program: leaving a touch a stop cut short, rising clear
// of the part (DESIGN.md, Safety: travel between touches goes via the clearance plane).
#pragma once

#include <functional>
#include <span>
#include <vector>

#include "hal/cmm.hpp"
#include "planner/touch_sequence.hpp"

namespace cmm::daemon {

// One planned motion as the one command it is: a guarded move for a rise, travel, descent or return;
// the probing search for a probe (its retract included; a miss is a result for the point, not a
// fault that stops the job). Faults propagate as the driver raises them.
hal::TouchResult run_motion(hal::Cmm& cmm, const planner::Motion& motion);

// Motions in order (a touch's, or the way home), `before_motion` before each; it may throw to end
// them between two (a stop() reaches only a motion that is running). Returns the probe's result.
hal::TouchResult run_motions(hal::Cmm& cmm, std::span<const planner::Motion> motions,
                           const std::function<void()>& before_motion = {});

// The motions that make `touch` with the ball at `at`: the planned ones when the ball is where they
// begin (to a micrometre), else the same sequence from here — a run that resumes, or that starts
// where the plate's measurement or homing left the ball.
std::vector<planner::Motion> motions_from(const hal::Vec3& at, std::span<const planner::Motion> planned,
                                          const planner::Touch& touch, double clearance_z,
                                          const description::MachineDescription& machine);

struct TouchSpeeds {
  double travel_mm_s = 0;  // 0: the machine's travel speed
  double probe_mm_s = 5;
};

// Straight up to clearance_z from where the ball is (a ball above the plane stays): how a cancelled
// job leaves the ball, safe from where any touch left it (its search start).
void rise_to_clearance(hal::Cmm& cmm, double clearance_z, const TouchSpeeds& speeds);

// After a stop in the middle of a touch: back along the search line to its start, then up to the
// clearance plane, so the ball leaves the way it came in (a straight rise from beside a wall or
// inside a bore could hit what the plan's approach avoided). `before_motion` as for run_touch.
void leave_touch(hal::Cmm& cmm, const hal::Vec3& start, const hal::Vec3& direction, double clearance_z,
                 const TouchSpeeds& speeds, const std::function<void()>& before_motion = {});

}  // namespace cmm::daemon
