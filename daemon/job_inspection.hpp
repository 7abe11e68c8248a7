// A job's features held against its nominal model: the nominal read (a mesh, scaled), placed in the
// reference's frame (as given, or fitted by point-to-plane ICP) and compared with the job's tolerances.
#pragma once

#include <optional>

#include "daemon/job_planning.hpp"
#include "daemon/job_request.hpp"
#include "daemon/model_store.hpp"
#include "planner/inspection.hpp"
#include "planner/measurement_result.hpp"

namespace cmm::daemon {

// Nothing when the request names no nominal. Throws RpcError model_error naming the nominal's file when
// it cannot be read or is a cloud, and when a fit does not converge onto the reference.
std::optional<planner::InspectionResult> inspect_job(const JobRequest& request, const ModelStore& models,
                                                     const ReferenceModel& reference, const planner::MeasurementResult& result);

}  // namespace cmm::daemon
