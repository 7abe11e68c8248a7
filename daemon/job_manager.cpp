// The job queue: submit, the worker that runs one job at a time, and the job.* methods' state rules.
#include "daemon/job_manager.hpp"

#include <chrono>

#include <spdlog/spdlog.h>

#include "hal/description/eigen_json.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/model_units_check.hpp"
#include "daemon/registration_check.hpp"
#include "daemon/storage_error.hpp"
#include "planner/tolerances_json.hpp"
#include "hal/utc_time.hpp"

namespace cmm::daemon {

namespace {

nlohmann::json record_json(const JobRecord& record) {
  nlohmann::json j = record;
  return j;
}

// The request as stored: every default filled in, so a job resumed after a config change runs
// with the values it was submitted with.
nlohmann::json normalized(nlohmann::json params, const JobRequest& r) {
  params["scale"] = r.scale;
  params["delta_mm"] = r.delta_mm;
  params["spacing_mm"] = r.spacing_mm;
  params["feature_angle_deg"] = r.feature_angle_deg;
  params["seed"] = r.seed;
  params["requalify"] = r.requalify;
  params["tolerances"] = planner::to_json(r.tolerances);
  nlohmann::json& reg = params["registration"];
  if (reg.contains("measure_plate")) reg["measure_plate"]["plate"] = description::to_json(r.plate);
  else reg["plate"] = description::to_json(r.plate);
  return params;
}

// The inspection's verdict and counts from the job's result.json, for the record (job.list shows it
// without every client reading every result).
nlohmann::json verdict_of(const JobStore& store, int id) {
  try {
    const std::optional<std::string> text = store.read(id, JobFile::result);
    if (!text) return nullptr;
    const nlohmann::json result = nlohmann::json::parse(*text);
    const nlohmann::json& inspection = result.at("inspection");
    if (inspection.is_null()) return nullptr;
    return {{"verdict", inspection.at("verdict")},
            {"coverage", inspection.value("coverage", "")},  // results from before coverage have none
            {"edge_points", inspection.at("counts").at("edge_points")},
            {"holes", inspection.at("counts").at("holes")}};
  } catch (const std::exception& e) {
    spdlog::warn("job {}: no verdict for its record: {}", id, e.what());
    return nullptr;
  }
}

std::string describe_current_exception() {
  try {
    throw;
  } catch (const std::exception& e) {
    return std::string("internal error: ") + e.what();
  } catch (...) {
    return "internal error of an unknown kind";
  }
}

}  // namespace

JobManager::JobManager(const DaemonConfig& config, MachineLink& machine, ModelStore& models, JobStore& store,
                       Notify notify, std::string version)
    : config_(config), machine_(machine), models_(models), store_(store), notify_(std::move(notify)),
      version_(std::move(version)) {}

JobManager::~JobManager() { shutdown(); }

void JobManager::start() {
  for (JobRecord& record : store_.recover()) {
    auto job = std::make_unique<Job>();
    job->record = std::move(record);
    try {
      job->request = parse_job_request(job->record.request, config_);
    } catch (const std::exception& e) {
      job->request_error = e.what();
    }
    if (job->record.state == JobState::interrupted)
      spdlog::warn("job {}: interrupted by the last restart ({}); job.resume continues it", job->record.id,
                   job->record.reason);
    const int id = job->record.id;
    jobs_[id] = std::move(job);
  }
  worker_ = std::thread([this] { worker(); });
}

void JobManager::shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && !worker_.joinable()) return;
    stopping_ = true;
    if (running_) {
      jobs_.at(*running_)->control.shutdown = true;
      try {
        machine_.cmm().stop();
      } catch (const std::exception& e) {
        spdlog::warn("stopping the machine for shutdown: {}", e.what());
      }
    }
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

JobManager::Job& JobManager::find(int id) {
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) throw RpcError(rpc_code::not_found, "no job " + std::to_string(id), {{"job", id}});
  return *it->second;
}

const JobManager::Job& JobManager::find(int id) const { return const_cast<JobManager*>(this)->find(id); }

void JobManager::notify_state(const Job& job) {
  notify_("job", "job.state",
          {{"job", job.record.id},
           {"state", to_string(job.record.state)},
           {"reason", job.record.reason},
           {"verdict", job.record.verdict}});
}

void JobManager::set_state(Job& job, JobState state, const std::string& reason, const std::optional<JobFault>& fault) {
  JobRecord next = job.record;
  next.state = state;
  next.reason = reason;
  next.fault = fault;
  next.updated = hal::utc_now();
  if (!is_running(state)) next.progress.eta_s = 0;
  next.verdict = state == JobState::done ? verdict_of(store_, job.record.id) : nlohmann::json(nullptr);
  try {
    store_.save(next);
  } catch (const std::exception& e) {
    spdlog::error("job {}: cannot save its record as {}: {}", job.record.id, to_string(state), e.what());
    // A job neither goes on nor ends done on a record job.json does not hold: the error goes back
    // to the runner, which holds the job (paused, storage full) instead. A hold or any other end is
    // kept as it is: job.json then still says the last state saved, which a restart reads as
    // interrupted if it was a running one, so the job stays resumable and loses nothing.
    if (is_running(state) || state == JobState::done) throw;
  }
  job.record = std::move(next);
  spdlog::info("job {}: {}{}{}", job.record.id, to_string(state), reason.empty() ? "" : ": ", reason);
  notify_state(job);
}

JobSink JobManager::sink_for(Job& job) {
  JobSink sink;
  sink.state = [this, &job](JobState state, const std::string& reason, const std::optional<JobFault>& fault) {
    // A job's last motion is behind it when it announces that it ended or holds: the machine is
    // free before anyone hears so, and a machine.home sent on that word is not refused as busy.
    if (!is_running(state)) lease_.reset();
    std::lock_guard lock(mutex_);
    // Cancelled before its run began: whatever the run says after is not the job's state.
    if (is_final(job.record.state)) return;
    // A cancel that came after the run decided to hold and before it said so is not lost to the pause
    // (ending_of keeps one that came before).
    if (state == JobState::paused && job.control.cancel) set_state(job, JobState::cancelled, "cancelled by the operator", std::nullopt);
    else set_state(job, state, reason, fault);
  };
  sink.progress = [this, &job](const JobProgress& progress) {
    nlohmann::json params;
    {
      std::lock_guard lock(mutex_);
      job.record.progress = progress;
      params = {{"job", job.record.id}, {"phase", progress.phase}, {"done", progress.done},
                {"total", progress.total}, {"eta_s", progress.eta_s}};
    }
    notify_("job", "job.progress", params);
  };
  sink.touched = [this, &job](int touch, const hal::TouchResult& r) {
    notify_("job", "job.touch",
            {{"job", job.record.id}, {"touch", touch}, {"contact", r.contact},
             {"centre", description::vec3_json(r.centre)}});
  };
  return sink;
}

void JobManager::worker() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    // The head of the queue: the oldest job not finished. Paused and interrupted jobs hold it.
    Job* head = nullptr;
    for (auto& [id, job] : jobs_)
      if (!is_final(job->record.state)) {
        head = job.get();
        break;
      }
    const bool runnable = head != nullptr && (head->record.state == JobState::queued ||
                                              (is_resumable(head->record.state) && head->resume_requested));
    if (!runnable) {
      wake_.wait(lock);
      continue;
    }
    if (!head->request) {
      set_state(*head, JobState::failed, "request.json no longer parses: " + head->request_error, std::nullopt);
      continue;
    }
    if (std::optional<MachineLink::Lease> lease = machine_.try_lease("job " + std::to_string(head->record.id)))
      lease_.emplace(std::move(*lease));
    else {  // a manual home or qualification holds the machine for one call
      wake_.wait_for(lock, std::chrono::milliseconds(100));
      continue;
    }
    const bool rehome = head->record.state == JobState::interrupted;
    const bool reregister = head->reregister;
    head->resume_requested = head->reregister = false;
    head->control.clear();
    if (!head->runner)
      head->runner = std::make_unique<JobRunner>(RunEnvironment{config_, machine_, models_, store_, version_},
                                                 head->record.id, *head->request, head->control, sink_for(*head));
    running_ = head->record.id;
    lock.unlock();
    try {
      head->runner->run(rehome, reregister);
    } catch (...) {
      // run() reports every outcome as a state; this is the last line, should reporting itself fail
      // (out of memory): the job fails, cmmd and the jobs behind it go on.
      const std::string why = describe_current_exception();
      spdlog::error("job {}: {}", head->record.id, why);
      try {
        const std::lock_guard relock(mutex_);
        set_state(*head, JobState::failed, why, JobFault{"Internal", why});
      } catch (...) {
        spdlog::critical("job {}: cannot even record that it failed", head->record.id);
      }
    }
    lease_.reset();
    lock.lock();
    running_.reset();
  }
}

nlohmann::json JobManager::submit(const nlohmann::json& params) {
  const JobRequest request = parse_job_request(params, config_);
  models_.resolve(request.model);  // refuse an unknown model now, not when the job comes up
  if (request.nominal) models_.resolve(request.nominal->model, "/nominal/model");
  // Before anything is queued: corners the plate rules out, then a model in the wrong unit or off
  // the plate they give (the second needs the first: it stands the model on those corners).
  check_request_registration(request, config_.description);
  check_request_units(request, models_, config_.description.travel_box);
  std::lock_guard lock(mutex_);
  if (stopping_) throw RpcError(rpc_code::shutting_down, "cmmd is stopping");
  auto job = std::make_unique<Job>();
  job->record = refusing_on_full_disk([&] { return store_.create(normalized(params, request), request.name, request.model); });
  job->request = request;
  const int id = job->record.id;
  jobs_[id] = std::move(job);
  spdlog::info("job {}: queued ({})", id, request.model);
  notify_("job", "job.state", {{"job", id}, {"state", "queued"}, {"reason", ""}});
  wake_.notify_all();
  return record_json(jobs_[id]->record);
}

nlohmann::json JobManager::get(int id) const {
  std::lock_guard lock(mutex_);
  return record_json(find(id).record);
}

nlohmann::json JobManager::list() const {
  std::lock_guard lock(mutex_);
  nlohmann::json jobs = nlohmann::json::array();
  for (const auto& [id, job] : jobs_) jobs.push_back(record_json(job->record));
  return {{"jobs", jobs}};
}

nlohmann::json JobManager::pause(int id) {
  std::lock_guard lock(mutex_);
  Job& job = find(id);
  if (is_final(job.record.state) || is_resumable(job.record.state))
    throw RpcError(rpc_code::invalid_state, "job " + std::to_string(id) + " is " + to_string(job.record.state),
                   {{"state", to_string(job.record.state)}});
  if (running_ == id && is_running(job.record.state)) job.control.pause = true;  // held after the current touch
  else set_state(job, JobState::paused, "operator pause", std::nullopt);
  return record_json(job.record);
}

nlohmann::json JobManager::resume(int id, bool reregister) {
  std::lock_guard lock(mutex_);
  Job& job = find(id);
  if (!is_resumable(job.record.state))
    throw RpcError(rpc_code::invalid_state,
                   "job " + std::to_string(id) + " is " + to_string(job.record.state) + ", not paused or interrupted",
                   {{"state", to_string(job.record.state)}});
  job.resume_requested = true;
  job.reregister = reregister;
  wake_.notify_all();
  return record_json(job.record);
}

nlohmann::json JobManager::cancel(int id) {
  std::lock_guard lock(mutex_);
  Job& job = find(id);
  if (is_final(job.record.state))
    throw RpcError(rpc_code::invalid_state, "job " + std::to_string(id) + " is already " + to_string(job.record.state),
                   {{"state", to_string(job.record.state)}});
  if (running_ == id && is_running(job.record.state)) {
    job.control.cancel = true;
    try {
      machine_.cmm().stop();
    } catch (const std::exception& e) {
      spdlog::warn("job {}: stopping the machine to cancel: {}", id, e.what());
    }
  } else {
    // The worker may hold the job already (taken from the queue, not yet planning; or a resumed one
    // not yet running): its run hears the cancel before any motion, and what it reports after this
    // final state is not recorded (sink_for).
    if (running_ == id) job.control.cancel = true;
    set_state(job, JobState::cancelled, "cancelled by the operator", std::nullopt);
    wake_.notify_all();
  }
  return record_json(job.record);
}

nlohmann::json JobManager::result(int id, const std::string& format) const {
  std::lock_guard lock(mutex_);
  const Job& job = find(id);
  if (job.record.state != JobState::done)
    throw RpcError(rpc_code::invalid_state, "job " + std::to_string(id) + " is " + to_string(job.record.state) + ", not done",
                   {{"state", to_string(job.record.state)}});
  if (format == "csv") {
    const std::optional<std::string> csv = store_.read(id, JobFile::result_csv);
    if (!csv) throw RpcError(rpc_code::not_found, "job " + std::to_string(id) + " has no result.csv");
    return {{"csv", *csv}, {"holes_csv", store_.read(id, JobFile::holes_csv).value_or("")}};
  }
  if (format == "qif") {
    const std::optional<std::string> qif = store_.read(id, JobFile::result_qif);
    if (!qif) throw RpcError(rpc_code::not_found, "job " + std::to_string(id) + " has no result.qif (done before cmmd wrote QIF)");
    return {{"qif", *qif}};
  }
  if (format == "html") {
    const std::optional<std::string> html = store_.read(id, JobFile::report);
    if (!html) throw RpcError(rpc_code::not_found, "job " + std::to_string(id) + " has no report.html (done before cmmd wrote reports)");
    return {{"html", *html}};
  }
  if (format != "json") throw_invalid_param("/format", "must be json, csv, qif or html");
  const std::optional<std::string> text = store_.read(id, JobFile::result);
  if (!text) throw RpcError(rpc_code::not_found, "job " + std::to_string(id) + " has no result.json");
  return nlohmann::json::parse(*text);
}

void JobManager::machine_stopped() {
  std::lock_guard lock(mutex_);
  if (running_) jobs_.at(*running_)->control.operator_stop = true;
}

std::optional<int> JobManager::running_job() const {
  std::lock_guard lock(mutex_);
  return running_;
}

}  // namespace cmm::daemon
