// The request's registration before the machine moves; see registration_check.hpp.
#include "daemon/registration_check.hpp"

#include <algorithm>

#include "daemon/client/rpc_error.hpp"
#include "planner/corner_probing.hpp"
#include "planner/number_text.hpp"
#include "planner/plate_pose.hpp"
#include "planner/registration.hpp"

namespace cmm::daemon {

namespace {

// How far apart two rough corners may be from the plate's length between them: each may be off by
// what a corner's touches still find (they keep edge_margin_mm inside their face and search
// search_mm either side of the nominal contact), so a length by twice that.
double rough_length_tolerance(const planner::CornerProbingOptions& o) {
  return 2 * std::min(o.edge_margin_mm, o.search_mm);
}

}  // namespace

void check_request_registration(const JobRequest& request, const description::MachineDescription& machine) {
  try {
    if (request.given) {
      planner::fit_registration(*request.given, &request.plate);
      return;
    }
    if (!request.measure) return;
    const PlateMeasurement& m = *request.measure;
    const planner::RegistrationOptions defaults;
    planner::check_plate_corners(m.ids, m.scan, 'S', "scan_corners (S)", request.plate, defaults.length_tolerance_mm);
    planner::CornerProbingOptions probing;
    probing.ball_radius_mm = machine.tip().ball_radius_mm;
    const double tolerance = rough_length_tolerance(probing);
    planner::check_plate_corners(m.ids, m.rough_machine, 'M',
                                 "rough_machine (M, the corners' touches find a corner within " +
                                     planner::fixed(tolerance / 2, 1) + " mm of where it was taught)",
                                 request.plate, tolerance);
    planner::plan_corner_touches(request.plate, planner::fit_plate_pose(request.plate, m.ids, m.rough_machine), probing);
  } catch (const planner::RegistrationError& e) {
    throw RpcError(rpc_code::registration_error, e.what(), {{"kind", planner::to_string(e.kind())}, {"corners", e.corners()}});
  }
}

}  // namespace cmm::daemon
