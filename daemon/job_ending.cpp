// The one mapping from what ended a run to the job's state; see job_ending.hpp.
#include "daemon/job_ending.hpp"

#include "daemon/client/rpc_error.hpp"
#include "daemon/storage_error.hpp"
#include "geometry/cancellation.hpp"
#include "hal/fault.hpp"

namespace cmm::daemon {

namespace {
const char* const cancelled_reason = "cancelled by the operator";
const char* const interrupted_reason = "cmmd stopped during the job";
}  // namespace

JobEnding ending_of(std::exception_ptr error, const JobControl& control) {
  try {
    std::rethrow_exception(error);
  } catch (const JobHold& hold) {
    // A cancel or a shutdown that came while the run was running into a hold (a tip to qualify, a
    // full disk) is not lost to the pause: what the operator or cmmd asked for wins.
    if (hold.ending().state == JobState::paused && control.cancel) return {JobState::cancelled, cancelled_reason, std::nullopt};
    if (hold.ending().state == JobState::paused && control.shutdown)
      return {JobState::interrupted, interrupted_reason, std::nullopt};
    return hold.ending();
  } catch (const geometry::Cancelled&) {
    // Planning heard the cancel or the shutdown.
    if (control.shutdown) return {JobState::interrupted, interrupted_reason, std::nullopt};
    return {JobState::cancelled, cancelled_reason, std::nullopt};
  } catch (const hal::Fault& fault) {
    // A stop the operator or cmmd asked for surfaces as the driver's Aborted; say why it came.
    if (control.cancel) return {JobState::cancelled, cancelled_reason, std::nullopt};
    if (control.shutdown) return {JobState::interrupted, interrupted_reason, std::nullopt};
    const std::string reason = control.operator_stop ? "operator stop" : std::string("machine fault: ") + fault.what();
    return {JobState::paused, reason, JobFault{hal::to_string(fault.kind()), fault.what()}};
  } catch (const RpcError& e) {
    return {JobState::failed, e.what(), JobFault{"Job", e.what()}};
  } catch (const hal::StateError& e) {
    return {JobState::paused, std::string("machine not ready: ") + e.what(), JobFault{"State", e.what()}};
  } catch (const std::exception& e) {
    // A file of the job that cannot be written (a full disk) holds the job: what it measured is
    // kept, and job.resume goes on once the operator has made room.
    if (const auto failure = storage_failure(e))
      return {JobState::paused, failure->hold_reason(), JobFault{failure->fault_kind(), e.what()}};
    return {JobState::failed, e.what(), JobFault{"Internal", e.what()}};
  } catch (...) {
    return {JobState::failed, "an error of an unknown kind", JobFault{"Internal", "an error of an unknown kind"}};
  }
}

}  // namespace cmm::daemon
