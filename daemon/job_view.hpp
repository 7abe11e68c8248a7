// job.view: what the dashboard draws of one job, gathered from its folder: the reference mesh, the
// planned edge points and holes with their touch ids, the touches made so far and, once the job is
// done, what each feature measured (docs/api.md, job.view).
#pragma once

#include <nlohmann/json.hpp>

#include "daemon/job_store.hpp"

namespace cmm::daemon {

// The view of job `job_id` as docs/api.md gives it. Each part is null (or empty) until the job has
// written the file it comes from: reference.ply once it loaded its model, registration.json once
// registered, plan.json once planned, result.json once done. Throws geometry::FileError for a file
// that cannot be read, nlohmann::json::exception or std::invalid_argument for one that is not what
// cmmd wrote.
nlohmann::json job_view(const JobStore& store, int job_id);

}  // namespace cmm::daemon
