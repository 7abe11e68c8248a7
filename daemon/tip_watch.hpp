// Keeps a job honest about its tip: before a run's first touch, and again whenever the driver has
// reconnected, the tip as the machine reports it is held against the qualification the job's
// touches were last made under (qualifications.json). Unchanged: on. Changed or vanished (a
// controller that restarted forgets it): the job takes on a qualification cmmd itself measured since
// (machine.qualify during the hold), or with `requalify` measures one itself; else it holds.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "daemon/job_qualifications.hpp"
#include "daemon/job_store.hpp"
#include "daemon/machine_link.hpp"

namespace cmm::daemon {

class TipWatch {
 public:
  // `check_stop` runs before each motion of a requalification and may throw to end it; the
  // requalification rises to `clearance_z` first (the plan's, which may lie above the machine's).
  TipWatch(MachineLink& machine, JobStore& store, int job_id, bool requalify, std::function<void()> check_stop);

  // The check. `reregister` starts the record afresh, as the journal is; `registered_tip` is the tip
  // the job was registered with (none before its registration). Throws JobHold (paused, fault kind
  // Qualification) when the job must wait for the operator. Returns the machine as it is afterwards.
  description::MachineDescription check(description::MachineDescription info, bool reregister,
                                        const std::optional<std::string>& registered_tip, double clearance_z);
  // The driver reconnected since the last check: the tip may have changed.
  bool reconnected() const { return machine_.connections() != checked_connections_; }

  void load();  // qualifications.json as it is, for a run that makes no touch
  const JobQualifications* qualifications() const { return record_ ? &*record_ : nullptr; }
  int current() const;  // the entry touches are made under now (a journal line's "q")

 private:
  void take_on(const description::StylusTip& tip, const std::string& source);
  void requalify(const std::string& tip_id, double clearance_z);
  void save(const JobQualifications& record);

  MachineLink& machine_;
  JobStore& store_;
  int id_;
  bool requalify_;
  std::function<void()> check_stop_;
  std::optional<JobQualifications> record_;
  std::uint64_t checked_connections_ = 0;  // MachineLink::connections() at the last check
};

}  // namespace cmm::daemon
