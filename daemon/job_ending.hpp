// How a run of a job ends when it does not end done: the state it leaves the job in, why, and the
// fault. A stage that must hold the job throws JobHold; ending_of() is the one place that turns
// whatever ended a run into its ending.
#pragma once

#include <exception>
#include <optional>
#include <stdexcept>
#include <string>

#include "daemon/job_control.hpp"
#include "daemon/job_record.hpp"
#include "daemon/job_state.hpp"

namespace cmm::daemon {

struct JobEnding {
  JobState state = JobState::failed;
  std::string reason;
  std::optional<JobFault> fault;
};

// A run held (paused, interrupted) or ended (cancelled) between two steps on purpose.
class JobHold : public std::runtime_error {
 public:
  JobHold(JobState state, const std::string& reason, std::optional<JobFault> fault = std::nullopt)
      : std::runtime_error(reason), ending_{state, reason, std::move(fault)} {}
  const JobEnding& ending() const { return ending_; }

 private:
  JobEnding ending_;
};

// The ending for what ended a run, given what was asked of it meanwhile: a cancel or a shutdown the
// stages heard (geometry::Cancelled) or that stopped the machine (the driver's Aborted); a hold (but
// a hold that would pause a job whose cancel or shutdown came meanwhile ends it as asked); a machine
// fault (paused, resumable); a job error (RpcError: failed); a machine not ready (paused); a
// file of the job that could not be written (paused: storage full); anything else failed (Internal).
JobEnding ending_of(std::exception_ptr error, const JobControl& control);

}  // namespace cmm::daemon
