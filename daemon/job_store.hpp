// One folder per job under the state dir (jobs/000042/: request.json, job.json, and the files the
// runner adds), every write atomic, so a daemon killed at any moment restarts with every job. The
// store owns the folder's file names: everyone else names a file by what it holds (JobFile).
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

// The files a job's run leaves in its folder (docs/result.md, Files).
enum class JobFile {
  reference_mesh,  // reference.ply: the mesh the job plans on (daemon/job_reference.hpp)
  reference_info,  // reference.json: where that mesh came from, and its sha256
  plan,            // plan.json
  registration,    // registration.json: T_M_S and the tip and radius the plan is made for
  touches,         // touches.jsonl: the journal
  qualifications,  // qualifications.json: the tip qualifications the touches were made under
  result,          // result.json, written last
  result_csv,      // result.csv
  holes_csv,       // result.holes.csv
  merged_cloud,    // merged.ply
  result_qif,      // result.qif: QIF 3.0 results (docs/qif.md)
  report,          // report.html: the self-contained report (docs/report.md)
};
const char* file_name(JobFile file);

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
  std::filesystem::path path(int id, JobFile file) const;

  // A job's file, written atomically; geometry::FileError on failure.
  void write(int id, JobFile file, std::string_view content);
  // Its content, or nullopt if the job has no such file yet.
  std::optional<std::string> read(int id, JobFile file) const;
  // Moves the file aside as name.before-<time stamp>.ext, kept for the record (a registration made
  // again starts a new journal); nothing when there is none. Throws when it cannot: the old file
  // must not stay where the new run would take it for its own.
  void set_aside(int id, JobFile file);
  // Removes the file (nothing when there is none), the folder synced.
  void remove(int id, JobFile file);

 private:
  std::filesystem::path jobs_dir_;
  int next_id_ = 1;
  mutable std::mutex mutex_;
};

}  // namespace cmm::daemon
