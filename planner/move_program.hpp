// The move program: touches in machine order, each reached by rising to the clearance plane,
// travelling there and descending to its approach start; with the machine-time estimate and its bound.
#pragma once

#include <vector>

#include "hal/description/machine_description.hpp"
#include "planner/touch.hpp"

namespace cmm::planner {

enum class MotionKind { rise, travel, descend, probe, retract };

const char* to_string(MotionKind kind);

// One straight motion of the ball centre, M.
struct Motion {
  MotionKind kind = MotionKind::travel;
  Vec3 from = Vec3::Zero(), to = Vec3::Zero();
  double speed_mm_s = 0;
  int touch = -1;     // the touch it leads to or belongs to
  double time_s = 0;  // trapezoidal, from the machine's speed and acceleration
};

struct MoveProgram {
  Vec3 home = Vec3::Zero();  // where the program starts and ends, on the clearance plane
  double clearance_z = 0;
  std::vector<Touch> touches;  // in machine order
  std::vector<Motion> motions;  // expanded: per touch rise, travel, descend, probe, retract; then home
  double time_s = 0;
  double lower_bound_s = 0;  // fixed per-touch costs plus a minimum spanning tree of the travel
};

// Orders the touches to minimise machine time and expands the motions between them. The rises,
// descents, searches and retracts cost the same in any order; only the travel on the clearance
// plane depends on it, so that is what is ordered and bounded.
MoveProgram build_program(std::vector<Touch> touches, const description::MachineDescription& machine, const Vec3& home,
                          double clearance_z);

}  // namespace cmm::planner
