// A finished job's documents beside its result: the HTML report (planner/job_report.hpp) and the QIF 3.0
// results (planner/qif_export.hpp), filled from what the job knows (station, machine, tip, registration).
#pragma once

#include <string>

#include "daemon/job_result.hpp"
#include "planner/measurement_result.hpp"

namespace cmm::daemon {

// Writes report.html and result.qif into the job's folder (each atomically).
void write_job_documents(JobStore& store, int job_id, const JobResultInputs& inputs, const planner::MeasurementResult& result);

}  // namespace cmm::daemon
