// Keeps a job honest about its tips: before a tip's first touch in a run, after every tip change and
// whenever the driver has reconnected, the tip as the machine reports it is held against the
// qualification the job's touches with it were last made under (qualifications.json). A tip never
// qualified is no tip to measure with unless the request allows it; a tip fitted by hand needs a
// qualification made since. Unchanged: on. Changed or vanished (a controller that restarted forgets
// it): the job takes on a qualification cmmd itself measured since (machine.qualify during the hold),
// or with `requalify` measures one itself; else it holds.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "daemon/job_qualifications.hpp"
#include "daemon/job_store.hpp"
#include "daemon/machine_link.hpp"

namespace cmm::daemon {

// What the request lets the watch do (docs/api.md, Job request).
struct TipRules {
  bool requalify = false;           // qualify a tip itself instead of holding for the operator
  bool allow_unqualified = false;   // touch with a tip's nominal radius and offset
};

class TipWatch {
 public:
  // `check_stop` runs before each motion of a requalification and may throw to end it; the
  // requalification rises to `clearance_z` first (the plan's, which may lie above the machine's).
  TipWatch(MachineLink& machine, JobStore& store, int job_id, TipRules rules, std::function<void()> check_stop);

  // The check of the machine's active tip. `reregister` starts the record afresh, as the journal is.
  // Throws JobHold (paused, fault kind Qualification) when the job must wait for the operator.
  // Returns the machine as it is afterwards.
  description::MachineDescription check(description::MachineDescription info, bool reregister, double clearance_z);
  // The driver reconnected since the last check: the tip may have changed.
  bool reconnected() const { return machine_.connections() != checked_connections_; }

  void load();  // qualifications.json as it is, for a run that makes no touch
  const JobQualifications* qualifications() const { return record_ ? &*record_ : nullptr; }
  int current() const;  // the entry touches are made under now (a journal line's "q")

  // A machine without a tool changer: the job asks the operator to fit `tip` (kept in
  // qualifications.json, so the run after the resume knows it was asked), and `fitting` says which
  // tip was asked for until its qualification is confirmed.
  void ask_fitting(const std::string& tip);
  std::optional<std::string> fitting() const { return record_ ? record_->fitting : std::nullopt; }

 private:
  description::MachineDescription first_use(description::MachineDescription info, const std::string& tip_id,
                                            double clearance_z);
  description::MachineDescription fitted_by_hand(description::MachineDescription info, const std::string& tip_id,
                                                 double clearance_z);
  // `info` after the job qualified `tip_id` itself, or a hold naming `why` when it may not.
  description::MachineDescription qualify_or_hold(const std::string& tip_id, const std::string& why,
                                                  const std::string& details, double clearance_z);
  void add_entry(const description::StylusTip& tip, const std::string& source);
  void take_on(const description::StylusTip& tip, const std::string& source);
  void requalify(const std::string& tip_id, double clearance_z);
  void save(const JobQualifications& record);

  MachineLink& machine_;
  JobStore& store_;
  int id_;
  TipRules rules_;
  std::function<void()> check_stop_;
  std::optional<JobQualifications> record_;
  std::string current_tip_;                // the active tip at the last check
  std::uint64_t checked_connections_ = 0;  // MachineLink::connections() at the last check
};

}  // namespace cmm::daemon
