// One job's run on the machine — planning, registering, probing, result — resumable at any point
// from its folder's files: registration.json keeps T_M_S and the radius, touches.jsonl every touch.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/job_record.hpp"
#include "daemon/job_request.hpp"
#include "daemon/job_qualifications.hpp"
#include "daemon/job_store.hpp"
#include "daemon/machine_link.hpp"
#include "daemon/model_store.hpp"
#include "daemon/touch_journal.hpp"
#include "hal/motion.hpp"
#include "planner/touch.hpp"
#include "planner/touch_sequence.hpp"

namespace cmm::daemon {

// Requests from other threads, read by the runner between steps (and a stop() makes the step in
// progress end at once).
struct JobControl {
  std::atomic<bool> pause{false};      // job.pause: hold after the current touch
  std::atomic<bool> cancel{false};     // job.cancel
  std::atomic<bool> shutdown{false};   // cmmd stopping: the job becomes interrupted
  std::atomic<bool> operator_stop{false};  // machine.stop or machine.abort during the job
  void clear() { pause = cancel = shutdown = operator_stop = false; }
};

// How the runner reports: the manager keeps the record, saves it and notifies clients.
struct JobSink {
  std::function<void(JobState, const std::string& reason, const std::optional<JobFault>&)> state;
  std::function<void(const JobProgress&)> progress;
  std::function<void(int touch_id, const hal::TouchResult&)> touched;
};

struct RunEnvironment {
  const DaemonConfig& config;
  MachineLink& machine;
  const ModelStore& models;
  JobStore& store;
  std::string version;  // cmmd's, for the result's traceability
};

class JobRunner {
 public:
  JobRunner(RunEnvironment env, int job_id, JobRequest request, JobControl& control, JobSink sink);

  // Runs until the job is done, failed, cancelled, paused or interrupted (the state it reports
  // last). `rehome` homes before any motion (a job interrupted by a restart); `reregister` measures
  // the plate again instead of keeping registration.json.
  void run(bool rehome, bool reregister);

 private:
  struct Registration;
  void prepare_machine(bool rehome);
  bool probing_complete() const;
  void journal_unjournaled();
  void load_qualifications();
  description::MachineDescription check_qualification(description::MachineDescription info, bool reregister);
  void take_on(const description::StylusTip& tip, const std::string& source);
  void requalify(const std::string& tip_id);
  Registration registration(bool reregister, double radius_mm, const std::string& tip);
  Registration measure_plate(double radius_mm);
  void check_control() const;
  void check_stop() const;  // between the motions of one touch: a stop, a cancel, a shutdown
  hal::TouchResult touch(const planner::Touch& t, std::span<const planner::Motion> motions);
  // Leaves a touch a stop cut short along its search line; `clear_of_part` (a cancel) also rises to
  // the clearance plane when no touch was in progress. Never throws: what went wrong is returned
  // (and logged), for a caller that must not move on without it.
  std::optional<std::string> finish_touch_safely(bool clear_of_part = false);

  RunEnvironment env_;
  int id_;
  JobRequest request_;
  JobControl& control_;
  JobSink sink_;
  // Touches made but not journalled (the journal could not be written): journalled first when the
  // job goes on, so a full disk loses no touch and makes none twice.
  std::vector<JournalEntry> unjournaled_;
  std::optional<JobQualifications> qualifications_;  // qualifications.json, once read or made
  std::uint64_t checked_connections_ = 0;            // MachineLink::connections() at the last check
};

}  // namespace cmm::daemon
