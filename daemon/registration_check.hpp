// The registration a job request carries, checked at job.submit before anything is queued or moves:
// everything the request and the plate's description settle without the machine. Swapped scan
// corners, a rough corner taught far off, a plate whose chamfer the ball cannot measure are refused
// here, naming the corner, instead of after the plate touches or as a bare EarlyTrigger.
#pragma once

#include "daemon/job_request.hpp"
#include "hal/description/machine_description.hpp"

namespace cmm::daemon {

// Given corners: the whole registration is fitted (planner::fit_registration: lengths, order, the
// fiducial), as the job would. measure_plate: the scan corners and the rough machine corners each
// against the plate (planner::check_plate_corners; the rough ones within what the corner touches'
// search and margins absorb), and the plate's touches planned for the active tip from the rough
// corners (a chamfer too narrow, a plate too thin for the ball). Throws RpcError registration_error,
// data {"kind", "corners"} (the corner ids to blame).
void check_request_registration(const JobRequest& request, const description::MachineDescription& machine);

}  // namespace cmm::daemon
