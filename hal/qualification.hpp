// Tip qualification: touch the reference sphere from the pole and a ring around it, fit a sphere to
// the ball centres, and record the tip's effective radius and offset (hal::Cmm::record_qualification).
#pragma once

#include <functional>
#include <string>

#include "hal/cmm.hpp"

namespace cmm::hal {

struct QualificationOptions {
  int touches = 9;              // ≥ 5: one from the pole, the rest spread around a ring
  double ring_latitude_deg = 30;  // above the sphere's equator; keeps clear of its stem
  double search_mm = 4;          // each search starts this far outside the nominal surface
  double speed_mm_s = 0;         // 0: the machine's probe speed
  // Runs before each motion, and once more before the result is recorded; may throw to end the
  // qualification there: a stop() reaches only a motion that is running.
  std::function<void()> before_motion;
};

// Selects `tip_id`, measures it and records the result, which it also returns. The moves between
// touches go over the sphere's pole at a safe height. The effective radius is the fitted radius
// less the sphere's; the offset is the current offset corrected by how far the fitted centre lies
// from the sphere's known centre. Throws std::invalid_argument for bad options and hal::Fault for
// what the machine reports (a miss means the sphere is not where the description says).
description::TipQualification qualify(Cmm& cmm, const std::string& tip_id, const QualificationOptions& options = {});

// How a driver that keeps the tips on its own side (Grbl, I++ DME) records a qualification: the
// tip's radius and offset become the qualified ones. Throws std::invalid_argument naming `owner`
// ("the Grbl driver's config") for an unknown tip.
void record_on(description::MachineDescription& machine, const std::string& tip_id,
               const description::TipQualification& q, const std::string& owner);

}  // namespace cmm::hal
