// The move program: touches in machine order and the motions that make them (planner/touch_sequence),
// from home and back, with the machine-time estimate and its lower bound.
#pragma once

#include <span>
#include <vector>

#include "hal/description/machine_description.hpp"
#include "planner/touch.hpp"
#include "planner/touch_sequence.hpp"

namespace cmm::planner {

struct MoveProgram {
  Vec3 home = Vec3::Zero();  // where the program starts and ends, on the clearance plane
  double clearance_z = 0;
  std::vector<Touch> touches;   // in machine order; the touches of one feature one after the other
  std::vector<Motion> motions;  // each touch's touch_motions from where the one before left the ball
                                // (from home for the first), then home_motions
  double time_s = 0;         // the motions' times
  double lower_bound_s = 0;  // fixed per-touch costs plus a minimum spanning tree of the travel
};

// Orders the touches to minimise machine time and expands the motions between them. Touches that
// follow one another in `touches` and measure one feature (an edge point's, a bore's) stay together
// — taken back to back, nothing drifts between the touches one point is computed from — each group
// entered at its nearer end: the groups are what is ordered. The rises, descents, searches and returns cost the
// same in any order; only the travel on the clearance plane depends on it, so that is what is
// ordered and bounded.
MoveProgram build_program(std::vector<Touch> touches, const description::MachineDescription& machine,
                          const Vec3& home, double clearance_z);
// The program of `touches` in the order given: their motions from home and back, the estimate and
// the bound (build_program's second half).
MoveProgram program_in_order(std::vector<Touch> touches, const description::MachineDescription& machine,
                             const Vec3& home, double clearance_z);

// The motions of the touch with id `touch_id`, one run of program.motions; empty when it has none.
std::span<const Motion> motions_of(const MoveProgram& program, int touch_id);
// The motions after the last touch's: the way home.
std::span<const Motion> home_motions_of(const MoveProgram& program);

}  // namespace cmm::planner
