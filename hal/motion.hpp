// The HAL's motion value types (DESIGN.md): a guarded travel, a probing search and its result.
// Positions are stylus-ball centres of the active tip in M, millimetres; speeds mm/s.
#pragma once

#include <string>

#include <Eigen/Core>

namespace cmm::hal {

using Vec3 = Eigen::Vector3d;

// Straight guarded travel of the ball centre to `target`; any probe trigger on the way is an
// EarlyTrigger fault. speed_mm_s 0 means the machine's travel speed.
struct Move {
  Vec3 target = Vec3::Zero();
  double speed_mm_s = 0;
};

// A search: the ball first travels (guarded) to `start` if it is not there, then moves along
// `direction` (unit, into the material) at speed_mm_s for at most max_travel_mm until the probe
// triggers, then backs off retract_mm along −direction. A trigger within min_travel_mm of `start`
// means the part is not where the plan thinks (or a spurious trigger): EarlyTrigger, not a touch.
// min_travel_mm is an extension of DESIGN.md's struct; 0 accepts a trigger anywhere.
struct ProbeMove {
  Vec3 start = Vec3::Zero();
  Vec3 direction = -Vec3::UnitZ();
  double max_travel_mm = 10;
  double speed_mm_s = 5;
  double retract_mm = 1;
  bool fail_on_miss = true;  // a miss raises NoContact; otherwise it returns contact = false
  double min_travel_mm = 0;
};

// What the machine saw. `centre` is the ball centre at the trigger (the HAL never reports a contact
// normal: a touch-trigger probe does not know it); `travel_mm` how far the search went from start;
// `t_s` the machine clock at the trigger (or at the end of a miss).
struct TouchResult {
  bool contact = false;
  Vec3 centre = Vec3::Zero();
  double travel_mm = 0;
  double t_s = 0;
  std::string tip_id;
};

}  // namespace cmm::hal
