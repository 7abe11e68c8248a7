// One job's run on the machine, in stages — model, machine, tip, registration, plan, probing,
// result — resumable at any point from its folder's files (JobStore): reference.ply keeps the mesh
// the job plans on (job_reference.hpp), registration.json keeps T_M_S
// and the radius the plan is made for, touches.jsonl every touch, qualifications.json the tip's
// qualifications. How a run that does not end done ends is ending_of()'s one mapping.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/job_control.hpp"
#include "daemon/job_ending.hpp"
#include "daemon/job_planning.hpp"
#include "daemon/job_record.hpp"
#include "daemon/job_reference.hpp"
#include "daemon/job_registration.hpp"
#include "daemon/job_request.hpp"
#include "daemon/job_store.hpp"
#include "daemon/machine_link.hpp"
#include "daemon/model_store.hpp"
#include "daemon/tip_watch.hpp"
#include "daemon/touch_journal.hpp"
#include "hal/motion.hpp"
#include "planner/measurement_plan.hpp"
#include "planner/touch.hpp"
#include "planner/touch_sequence.hpp"

namespace cmm::daemon {

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
  // The touches of the plan made so far (earlier runs' from the journal), by plan touch id, with the
  // qualification each was made under.
  struct Touches {
    std::map<int, hal::TouchResult> results;
    std::map<int, int> qualification_of;
    double probing_time_s = 0;  // machine time of this run's probing stage
  };

  // The stages, in the order run() takes them; each throws to end the run.
  ReferenceModel load_model();
  void prepare_machine(bool rehome);  // up, reset, a touch a stop cut short left, homed
  std::vector<std::string> tips_for_registration(const description::MachineDescription& info) const;
  static std::vector<std::string> planned_tip_ids(const JobRegistration& registration);
  description::MachineDescription check_tip(bool reregister, bool probed, bool registered,
                                            const std::vector<std::string>& tips);
  description::MachineDescription use_tip(const std::string& id, bool reregister);
  JobRegistration register_part(bool reregister, const std::vector<std::string>& tips,
                                const description::MachineDescription& info);
  description::MachineDescription machine_for_plan(const description::MachineDescription& info,
                                                   const JobRegistration& registration) const;
  planner::MeasurementPlan plan(const ReferenceModel& model, const JobRegistration& registration,
                                const description::MachineDescription& machine);
  Touches probe(const planner::MeasurementPlan& plan, const description::MachineDescription& machine, bool probed);
  void end(const JobEnding& ending);

  JobRegistration measure_plate(double radius_mm);
  std::optional<JobRegistration> kept_registration() const;
  bool probing_complete() const;
  void journal_unjournaled();
  void check_control() const;
  void check_stop() const;  // between the motions of one touch: a stop, a cancel, a shutdown
  // `keep` (the job's touches: the journal) takes the probe's result before the way back to the start.
  hal::TouchResult touch(const planner::Touch& t, std::span<const planner::Motion> motions,
                         const std::function<void(const hal::TouchResult&)>& keep = {});
  // Leaves a touch a stop cut short along its search line; `clear_of_part` (a cancel) also rises to
  // the clearance plane when no touch was in progress. Never throws: what went wrong is returned
  // (and logged), for a caller that must not move on without it.
  std::optional<std::string> finish_touch_safely(bool clear_of_part = false);
  double clearance_z() const;  // the plan's clearance plane, once there is a plan; else the machine's

  RunEnvironment env_;
  int id_;
  JobRequest request_;
  JobControl& control_;
  JobSink sink_;
  TipWatch tip_;
  // Touches made but not journalled (the journal could not be written): journalled first when the
  // job goes on, so a full disk loses no touch and makes none twice.
  std::vector<JournalEntry> unjournaled_;
  // Where this run's reference mesh came from (JobReference::provenance), for plan.json and the result.
  nlohmann::json reference_mesh_;
};

}  // namespace cmm::daemon
