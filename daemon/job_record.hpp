// What cmmd knows about one job, as job.get returns it and job.json stores it (docs/api.md, Job
// record); the request it was submitted with travels beside it and is stored as request.json.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/job_state.hpp"

namespace cmm::daemon {

struct JobProgress {
  std::string phase;  // what the job is doing now, e.g. "probing"
  int done = 0;       // units of the phase finished (touches, corners)
  int total = 0;
  double eta_s = 0;  // seconds until the phase ends, as estimated now
};

// Why a job paused or failed: a machine fault's kind ("EStop", …) or the job's own ("planning").
struct JobFault {
  std::string kind;
  std::string message;
};

struct JobRecord {
  int id = 0;
  std::string name;
  JobState state = JobState::queued;
  std::string reason;  // why the job is in its state, e.g. "operator stop"; empty when nothing to say
  std::string model;   // "sha256:<hex>" or "file:<name>"
  std::string created, updated;  // ISO 8601 UTC
  JobProgress progress;
  std::optional<JobFault> fault;
  // A done job's inspection verdict: {"verdict", "edge_points": counts, "holes": counts}; null when it
  // named no nominal (or is not done).
  nlohmann::json verdict = nullptr;
  nlohmann::json request;  // the job.submit params; not part of the record's JSON
};

void to_json(nlohmann::json& j, const JobProgress& progress);
void from_json(const nlohmann::json& j, JobProgress& progress);
void to_json(nlohmann::json& j, const JobFault& fault);
void from_json(const nlohmann::json& j, JobFault& fault);
// The record as docs/api.md gives it, without the request. from_json leaves `request` alone and
// throws nlohmann::json::exception for a missing or mistyped field, std::invalid_argument for an
// unknown state.
void to_json(nlohmann::json& j, const JobRecord& record);
void from_json(const nlohmann::json& j, JobRecord& record);

}  // namespace cmm::daemon
