// What a test waits for among a job's notifications (job.state, job.progress, job.touch), and the
// 10 mm sample job the crash, storage and qualification tests run.
#pragma once

#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/client/rpc_client.hpp"

namespace cmm::testing {

// A predicate on a notification ({"method", "params"}).
using NotificationMatch = std::function<bool(const nlohmann::json&)>;

NotificationMatch job_state_is(int job, const std::string& state);
// job.progress of `phase` with at least `done` done.
NotificationMatch job_progress_at_least(int job, const std::string& phase, int done);
NotificationMatch job_touched(int job);

inline const std::set<std::string> job_ended = {"done", "failed", "cancelled"};
inline const std::set<std::string> job_ended_or_held = {"done", "failed", "cancelled", "paused", "interrupted"};

// Notifications until `match`; the job reaching one of `failing` first throws std::runtime_error
// naming the state, its reason and `what` was awaited.
nlohmann::json await_job(daemon::RpcClient& watch, int job, const std::string& what, const NotificationMatch& match,
                         double timeout_s, const std::set<std::string>& failing);

// The sample job at 10 mm spacing: 176 touches instead of 712, every kind still there (plate,
// edge, face and bore touches), the plate measured on the machine.
nlohmann::json spaced_job_request(const std::filesystem::path& scan_folder);

// plan.json's touch ids in machine order: the order a job makes them in, and so its journal's.
std::vector<int> program_order(const std::filesystem::path& job_folder);

}  // namespace cmm::testing
