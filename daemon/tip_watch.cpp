// The tip check before touches, taking on a new qualification, and the job's own requalification.
#include "daemon/tip_watch.hpp"

#include <algorithm>
#include <cmath>

#include <spdlog/spdlog.h>

#include "daemon/job_ending.hpp"
#include "daemon/touch_motion.hpp"
#include "hal/utc_time.hpp"

namespace cmm::daemon {

namespace {
// A qualification that moves the radius by more than this is no requalification of the tip the job
// was planned for (ten times a qualification's repeatability): the plan is made afresh instead.
constexpr double max_radius_change_mm = 0.01;
}  // namespace

TipWatch::TipWatch(MachineLink& machine, JobStore& store, int job_id, bool requalify, std::function<void()> check_stop)
    : machine_(machine), store_(store), id_(job_id), requalify_(requalify), check_stop_(std::move(check_stop)) {}

int TipWatch::current() const { return record_ ? static_cast<int>(record_->list.size()) - 1 : 0; }

void TipWatch::load() {
  if (record_) return;
  if (const std::optional<std::string> text = store_.read(id_, JobFile::qualifications))
    record_ = job_qualifications_from_json(nlohmann::json::parse(*text));
}

void TipWatch::save(const JobQualifications& record) {
  store_.write(id_, JobFile::qualifications, to_json(record).dump(1) + "\n");
  record_ = record;
}

description::MachineDescription TipWatch::check(description::MachineDescription info, bool reregister,
                                                const std::optional<std::string>& registered_tip, double clearance_z) {
  checked_connections_ = machine_.connections();
  if (reregister) {
    store_.set_aside(id_, JobFile::qualifications);
    record_.reset();
  } else {
    load();
  }
  const std::string tip_id = record_ ? record_->tip : registered_tip.value_or(info.active_tip);
  const description::StylusTip* now = info.find_tip(tip_id);
  if (now == nullptr || tip_id != info.active_tip) return info;  // the tip check before planning holds the job
  if (!record_) {
    const char* source = reregister       ? "in force when the job was registered again (reregister)"
                         : registered_tip ? "in force when cmmd first checked it (the job began before its "
                                            "qualifications were recorded)"
                                          : "in force when the job began";
    JobQualifications first{tip_id, {in_force(*now, source)}};
    first.list.front().since_utc = hal::utc_now();
    save(first);
    return info;
  }
  const QualificationInForce& last = record_->list.back();
  if (same_qualification(last, *now)) return info;
  if (const std::optional<description::StylusTip> measured = machine_.qualified_by_cmmd(tip_id);
      measured && now->qualification && same_qualification(in_force(*measured, ""), *now)) {
    take_on(*now, "machine.qualify while the job was held");
    return info;
  }
  const std::string details = "the job's touches so far were made with " + describe(last) +
                              "; the machine now reports " + describe(in_force(*now, ""));
  if (requalify_) {
    spdlog::warn("job {}: tip {}: {}; qualifying it again (requalify)", id_, tip_id, details);
    requalify(tip_id, clearance_z);
    info = machine_.cmm().info();
    if (const description::StylusTip* qualified = info.find_tip(tip_id))
      take_on(*qualified, "qualified by the job (requalify)");
    return info;
  }
  const char* what = last.qualification && !now->qualification ? "vanished" : "changed";
  throw JobHold(JobState::paused,
                "tip " + tip_id + "'s qualification " + what + " since the job began: machine.qualify, then job.resume",
                JobFault{"Qualification", details});
}

// The touches from here on are made, and compensated, with the tip as it is now. Before the
// registration nothing is measured yet, and the new one simply replaces the old.
void TipWatch::take_on(const description::StylusTip& tip, const std::string& source) {
  JobQualifications next = *record_;
  const QualificationInForce planned = next.list.front();
  if (!store_.read(id_, JobFile::registration)) {
    next.list.clear();
  } else if (std::abs(tip.ball_radius_mm - planned.ball_radius_mm) > max_radius_change_mm) {
    throw JobHold(JobState::paused,
                  "tip " + tip.id + "'s radius is now " + describe(in_force(tip, "")) + ", the job was planned for " +
                      describe(planned) + ": not the same tip; job.resume with reregister plans the job afresh",
                  JobFault{"Qualification", "radius changed by more than 0.01 mm"});
  }
  QualificationInForce q = in_force(tip, source);
  q.since_utc = hal::utc_now();
  next.list.push_back(std::move(q));
  save(next);
  spdlog::info("job {}: tip {} now {} ({}); the touches from here on are made with it", id_, tip.id,
               describe(record_->list.back()), source);
}

// hal::qualify as machine.qualify does it, from between two touches: up to the clearance plane and
// across it to above the reference sphere first; the qualification's own moves start from there.
void TipWatch::requalify(const std::string& tip_id, double clearance_z) {
  hal::Cmm& cmm = machine_.cmm();
  check_stop_();
  rise_to_clearance(cmm, clearance_z, {});
  check_stop_();
  const hal::Vec3 at = cmm.status().position, sphere = cmm.info().reference_sphere.centre;
  cmm.move({hal::Vec3(sphere.x(), sphere.y(), at.z()), 0});
  hal::QualificationOptions options;
  options.before_motion = check_stop_;
  const description::TipQualification q = machine_.qualify(tip_id, options);
  spdlog::info("job {}: tip {} qualified: r {:.5f} mm, rms {:.5f} mm", id_, tip_id, q.ball_radius_mm, q.residual_rms_mm);
}

}  // namespace cmm::daemon
