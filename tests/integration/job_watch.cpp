// Waiting on a job's notifications, and the 10 mm sample job (job_watch.hpp).
#include "job_watch.hpp"

#include <stdexcept>

#include "cmmd_instance.hpp"

namespace cmm::testing {

using nlohmann::json;

NotificationMatch job_state_is(int job, const std::string& state) {
  return [=](const json& n) {
    return n.at("method") == "job.state" && n["params"].at("job") == job && n["params"].at("state") == state;
  };
}

NotificationMatch job_progress_at_least(int job, const std::string& phase, int done) {
  return [=](const json& n) {
    const json& p = n.at("params");
    return n.at("method") == "job.progress" && p.at("job") == job && p.at("phase") == phase &&
           p.at("done").get<int>() >= done;
  };
}

NotificationMatch job_touched(int job) {
  return [=](const json& n) { return n.at("method") == "job.touch" && n["params"].at("job") == job; };
}

json await_job(daemon::RpcClient& watch, int job, const std::string& what, const NotificationMatch& match,
               double timeout_s, const std::set<std::string>& failing) {
  return wait_for_notification(
      watch, what,
      [&](const json& n) {
        if (match(n)) return true;
        const json& p = n.at("params");
        if (n.at("method") == "job.state" && p.at("job") == job && failing.contains(p.at("state").get<std::string>()))
          throw std::runtime_error("job " + std::to_string(job) + " became " + p.at("state").get<std::string>() + " (" +
                                   p.value("reason", "") + ") while waiting for " + what);
        return false;
      },
      timeout_s);
}

json spaced_job_request(const std::filesystem::path& scan_folder) {
  return {{"registration", sample_measure_plate(scan_folder)}, {"seed", 1}, {"spacing_mm", 10}};
}

std::vector<int> program_order(const std::filesystem::path& job_folder) {
  const json plan = read_json_file(job_folder / "plan.json");
  std::vector<int> ids;
  for (const json& t : plan.at("program")) ids.push_back(t.at("id").get<int>());
  return ids;
}

}  // namespace cmm::testing
