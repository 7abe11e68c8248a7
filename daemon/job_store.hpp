// One folder per job under the state dir (jobs/000042/: request.json, job.json, and the files the
// runner adds), every write atomic, so a daemon killed at any moment restarts with every job.
#pragma once

#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/job_record.hpp"

namespace cmm::daemon {

class JobStore {
 public:
  // Creates `jobs_dir` if missing and finds the next free id.
  explicit JobStore(std::filesystem::path jobs_dir);

  // Every job, in id order, with its request. A job left planning, registering or probing by a
  // restart becomes interrupted (reason "cmmd restarted during <state>") and is saved so. A folder
  // without job.json (a crash inside create) is logged and skipped; its id is never reused. A job
  // file that cannot be read or parsed is geometry::FileError naming it.
  std::vector<JobRecord> recover();

  // A new queued job with the next id: its folder, request.json, then job.json, each durable
  // before this returns. When a write fails (a full disk: geometry::FileError with its errno) the
  // folder is removed again and the id stays free.
  JobRecord create(const nlohmann::json& request, std::string name, std::string model);

  // Replaces the job's job.json (the caller sets `updated`); geometry::FileError on failure. Each
  // job folder keeps a small allocated spare (.job.json.spare) that the next save writes into, so a
  // record still saves on a full disk; the spare is taken again from the old record's space.
  void save(const JobRecord& record);

  std::filesystem::path folder(int id) const;

  // A job's other files (plan.json, result.json, …), written atomically. `name` is a plain file
  // name (no folder, not job.json or request.json): std::invalid_argument otherwise.
  void write_file(int id, const std::string& name, std::string_view content);
  // The file's content, or nullopt if the job has no such file.
  std::optional<std::string> read_file(int id, const std::string& name) const;

 private:
  std::filesystem::path jobs_dir_;
  int next_id_ = 1;
  mutable std::mutex mutex_;
};

}  // namespace cmm::daemon
