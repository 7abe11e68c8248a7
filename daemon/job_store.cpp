// Job folders on disk: numbered folders, JSON files written with write_atomically, recovery that
// turns the jobs a restart cut short into interrupted ones.
#include "daemon/job_store.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "geometry/atomic_file.hpp"
#include "geometry/file_error.hpp"
#include "hal/utc_time.hpp"

namespace cmm::daemon {

namespace fs = std::filesystem;

namespace {
constexpr const char* record_file = "job.json";
constexpr const char* request_file = "request.json";
// Space kept aside in each job folder for job.json: a job's state can still be saved on a full disk,
// so that job.json says what cmmd says (paused, storage full) rather than what it said before.
constexpr const char* spare_file = ".job.json.spare";
constexpr std::size_t spare_bytes = 16 * 1024;

// job.json replaced atomically: through the spare when there is one (no new space needed; the old
// job.json's blocks are what the next spare takes), else the ordinary way. Throws geometry::FileError.
void write_record(const fs::path& dir, const std::string& content) {
  if (!geometry::write_through_spare(dir / record_file, dir / spare_file, content, spare_bytes))
    geometry::write_atomically(dir / record_file, content);
  geometry::allocate_spare(dir / spare_file, spare_bytes);
}

// The id a job folder's name spells ("000042" → 42), or nullopt for anything else in jobs_dir.
std::optional<int> folder_id(const fs::directory_entry& entry) {
  const std::string name = entry.path().filename().string();
  if (!entry.is_directory() || name.empty() || name.size() > 9) return std::nullopt;
  if (!std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; })) return std::nullopt;
  return std::stoi(name);
}

std::vector<int> folder_ids(const fs::path& jobs_dir) {
  std::vector<int> ids;
  for (const auto& entry : fs::directory_iterator(jobs_dir))
    if (const auto id = folder_id(entry)) ids.push_back(*id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::optional<std::string> read_whole(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    if (!fs::exists(file)) return std::nullopt;
    throw geometry::FileError::whole(file, "cannot open");
  }
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw geometry::FileError::whole(file, "read error");
  return buffer.str();
}

nlohmann::json parse_file(const fs::path& file, const std::string& text) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw geometry::FileError::at_byte(file, e.byte, std::string("not JSON: ") + e.what());
  } catch (const nlohmann::json::exception& e) {  // a number beyond a double's range (1e400)
    throw geometry::FileError::whole(file, std::string("not JSON: ") + e.what());
  }
}

JobRecord read_record(const fs::path& folder, int id, const std::string& text) {
  const fs::path file = folder / record_file;
  JobRecord record;
  try {
    parse_file(file, text).get_to(record);
  } catch (const geometry::FileError&) {
    throw;
  } catch (const std::exception& e) {
    throw geometry::FileError::whole(file, std::string("not a job record: ") + e.what());
  }
  if (record.id != id) throw geometry::FileError::whole(file, "holds job " + std::to_string(record.id) + ", not " + std::to_string(id));
  const fs::path request = folder / request_file;
  const auto request_text = read_whole(request);
  if (!request_text) throw geometry::FileError::whole(request, "missing beside " + file.string());
  record.request = parse_file(request, *request_text);
  return record;
}

// A job whose job.json is unreadable (a disk error, an operator's edit) comes back from what the
// folder still holds rather than stopping cmmd from starting: its touches stay, and the operator
// decides. With result.json beside it the job had finished; otherwise it is resumable.
JobRecord rebuild_record(const fs::path& folder, int id, const std::string& why) {
  JobRecord record;
  record.id = id;
  record.created = record.updated = hal::utc_now();
  const bool finished = fs::exists(folder / file_name(JobFile::result));
  record.state = finished ? JobState::done : JobState::interrupted;
  record.reason = "job.json was unreadable (" + why + "); rebuilt from the job folder";
  record.progress.phase = to_string(record.state);
  try {
    if (const auto text = read_whole(folder / request_file)) record.request = parse_file(folder / request_file, *text);
  } catch (const std::exception& e) {
    spdlog::error("job store: job {}: {}", id, e.what());  // the job manager fails the job for it
  }
  if (record.request.is_object()) {
    if (record.request.contains("name") && record.request["name"].is_string())
      record.name = record.request["name"].get<std::string>();
    if (record.request.contains("model") && record.request["model"].is_string())
      record.model = record.request["model"].get<std::string>();
  }
  return record;
}

// A restart must not stop at a job it cannot save (a full disk): the record comes back as read and
// rewritten in memory; job.json keeps what it said, which the next start reads the same way.
void save_recovered(const fs::path& dir, const JobRecord& record) {
  try {
    write_record(dir, nlohmann::json(record).dump(2));
  } catch (const std::exception& e) {
    spdlog::error("job store: job {} is {} but cannot be saved so: {}", record.id, to_string(record.state), e.what());
  }
}

}  // namespace

const char* file_name(JobFile file) {
  switch (file) {
    case JobFile::reference_mesh: return "reference.ply";
    case JobFile::reference_info: return "reference.json";
    case JobFile::plan: return "plan.json";
    case JobFile::registration: return "registration.json";
    case JobFile::touches: return "touches.jsonl";
    case JobFile::qualifications: return "qualifications.json";
    case JobFile::result: return "result.json";
    case JobFile::result_csv: return "result.csv";
    case JobFile::holes_csv: return "result.holes.csv";
    case JobFile::merged_cloud: return "merged.ply";
    case JobFile::result_qif: return "result.qif";
    case JobFile::report: return "report.html";
  }
  return "?";
}

JobStore::JobStore(fs::path jobs_dir) : jobs_dir_(std::move(jobs_dir)) {
  fs::create_directories(jobs_dir_);
  const auto ids = folder_ids(jobs_dir_);
  if (!ids.empty()) next_id_ = ids.back() + 1;
}

fs::path JobStore::folder(int id) const {
  char name[16];
  std::snprintf(name, sizeof name, "%06d", id);
  return jobs_dir_ / name;
}

std::vector<JobRecord> JobStore::recover() {
  std::lock_guard lock(mutex_);
  std::vector<JobRecord> jobs;
  for (const int id : folder_ids(jobs_dir_)) {
    next_id_ = std::max(next_id_, id + 1);
    const fs::path dir = folder(id);
    const auto text = read_whole(dir / record_file);
    if (!text) {
      spdlog::warn("job store: {} has no {} (cmmd stopped while creating the job); skipped", dir.string(), record_file);
      continue;
    }
    JobRecord record;
    try {
      record = read_record(dir, id, *text);
    } catch (const std::exception& e) {
      spdlog::error("job store: {}", e.what());
      record = rebuild_record(dir, id, e.what());
      save_recovered(dir, record);
    }
    if (is_running(record.state)) {
      record.reason = std::string("cmmd restarted during ") + to_string(record.state);
      record.state = JobState::interrupted;
      record.updated = hal::utc_now();
      save_recovered(dir, record);
      spdlog::info("job store: job {} interrupted ({})", id, record.reason);
    }
    jobs.push_back(std::move(record));
  }
  return jobs;
}

JobRecord JobStore::create(const nlohmann::json& request, std::string name, std::string model) {
  std::lock_guard lock(mutex_);
  JobRecord record;
  // A folder that appeared since the scan (another writer, or an operator) is skipped, not reused.
  while (!fs::create_directory(folder(next_id_))) ++next_id_;
  record.id = next_id_++;
  const fs::path dir = folder(record.id);
  record.name = std::move(name);
  record.model = std::move(model);
  record.created = record.updated = hal::utc_now();
  record.progress.phase = to_string(JobState::queued);
  record.request = request;
  try {
    geometry::sync_folder(jobs_dir_);
    geometry::write_atomically(dir / request_file, request.dump(2));
    write_record(dir, nlohmann::json(record).dump(2));
  } catch (...) {
    // No job half made (a full disk): the folder goes, and its id with it is free again.
    std::error_code ignored;
    fs::remove_all(dir, ignored);
    next_id_ = record.id;
    throw;
  }
  return record;
}

void JobStore::save(const JobRecord& record) {
  std::lock_guard lock(mutex_);
  const fs::path dir = folder(record.id);
  if (!fs::is_directory(dir)) throw geometry::FileError::whole(dir, "no such job folder (job " + std::to_string(record.id) + ")");
  write_record(dir, nlohmann::json(record).dump(2));
}

fs::path JobStore::path(int id, JobFile file) const { return folder(id) / file_name(file); }

void JobStore::write(int id, JobFile file, std::string_view content) {
  std::lock_guard lock(mutex_);
  const fs::path dir = folder(id);
  if (!fs::is_directory(dir)) throw geometry::FileError::whole(dir, "no such job folder (job " + std::to_string(id) + ")");
  geometry::write_atomically(dir / file_name(file), content);
}

std::optional<std::string> JobStore::read(int id, JobFile file) const {
  std::lock_guard lock(mutex_);
  return read_whole(path(id, file));
}

void JobStore::set_aside(int id, JobFile file) {
  std::lock_guard lock(mutex_);
  const fs::path from = path(id, file);
  if (!fs::exists(from)) return;
  fs::path to = from.parent_path() / (from.stem().string() + ".before-" + hal::utc_now() + from.extension().string());
  fs::rename(from, to);
  geometry::sync_folder(from.parent_path());
}

void JobStore::remove(int id, JobFile file) {
  std::lock_guard lock(mutex_);
  const fs::path p = path(id, file);
  if (!fs::remove(p)) return;
  geometry::sync_folder(p.parent_path());
}

}  // namespace cmm::daemon
