// The job queue behind the job.* methods: one worker owns the machine and runs jobs FIFO, holding
// at a paused or interrupted job until the operator resumes or cancels it (DESIGN.md job states).
#pragma once

#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "daemon/job_runner.hpp"

namespace cmm::daemon {

class JobManager {
 public:
  // topic ("job"), method ("job.state"), params: what subscribed clients are sent.
  using Notify = std::function<void(const std::string&, const std::string&, const nlohmann::json&)>;

  JobManager(const DaemonConfig& config, MachineLink& machine, ModelStore& models, JobStore& store, Notify notify,
             std::string version);
  ~JobManager();
  JobManager(const JobManager&) = delete;
  JobManager& operator=(const JobManager&) = delete;

  // Reads every job back (running ones become interrupted) and starts the worker.
  void start();
  // Stops the machine under a running job (it becomes interrupted, to be resumed after the restart)
  // and joins the worker. Idempotent.
  void shutdown();

  // The job.* methods (docs/api.md); each throws RpcError.
  nlohmann::json submit(const nlohmann::json& params);
  nlohmann::json get(int id) const;
  nlohmann::json list() const;
  nlohmann::json pause(int id);
  nlohmann::json resume(int id, bool reregister);
  nlohmann::json cancel(int id);
  nlohmann::json result(int id, const std::string& format) const;

  // machine.stop / machine.abort were called: a running job pauses ("operator stop").
  void machine_stopped();
  std::optional<int> running_job() const;
  // The job folders, for the readers of a job's files (job.view).
  const JobStore& store() const { return store_; }

 private:
  struct Job {
    JobRecord record;
    std::optional<JobRequest> request;  // parsed once; empty if request.json no longer parses
    std::string request_error;
    JobControl control;
    bool resume_requested = false;
    bool reregister = false;
    std::unique_ptr<JobRunner> runner;  // kept between runs: it remembers a touch cut short
  };

  void worker();
  Job& find(int id);
  const Job& find(int id) const;
  void set_state(Job& job, JobState state, const std::string& reason, const std::optional<JobFault>& fault);
  void notify_state(const Job& job);
  JobSink sink_for(Job& job);

  const DaemonConfig& config_;
  MachineLink& machine_;
  ModelStore& models_;
  JobStore& store_;
  Notify notify_;
  std::string version_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::map<int, std::unique_ptr<Job>> jobs_;
  std::optional<int> running_;
  // The running job's hold on the machine; only the worker thread (and the job's sink, which runs
  // on it) touches it.
  std::optional<MachineLink::Lease> lease_;
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace cmm::daemon
