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

TipWatch::TipWatch(MachineLink& machine, JobStore& store, int job_id, TipRules rules, std::function<void()> check_stop)
    : machine_(machine), store_(store), id_(job_id), rules_(rules), check_stop_(std::move(check_stop)) {}

int TipWatch::current() const { return record_ ? record_->current(current_tip_).value_or(0) : 0; }

void TipWatch::load() {
  if (record_) return;
  if (const std::optional<std::string> text = store_.read(id_, JobFile::qualifications))
    record_ = job_qualifications_from_json(nlohmann::json::parse(*text));
}

void TipWatch::save(const JobQualifications& record) {
  store_.write(id_, JobFile::qualifications, to_json(record).dump(1) + "\n");
  record_ = record;
}

void TipWatch::ask_fitting(const std::string& tip) {
  load();
  JobQualifications next = record_.value_or(JobQualifications{tip, {}, {}, {}});
  if (next.fitting == tip) return;
  next.fitting = tip;
  next.fitting_since_utc = hal::utc_now();
  save(next);
}

description::MachineDescription TipWatch::check(description::MachineDescription info, bool reregister, double clearance_z) {
  checked_connections_ = machine_.connections();
  if (reregister) {
    store_.set_aside(id_, JobFile::qualifications);
    record_.reset();
  } else {
    load();
  }
  const std::string tip_id = info.active_tip;
  const description::StylusTip* now = info.find_tip(tip_id);
  if (now == nullptr) return info;  // planning names the missing tip
  current_tip_ = tip_id;
  if (record_ && record_->fitting == tip_id) return fitted_by_hand(std::move(info), tip_id, clearance_z);
  const std::optional<int> k = record_ ? record_->current(tip_id) : std::nullopt;
  if (!k) return first_use(std::move(info), tip_id, clearance_z);

  const QualificationInForce& last = record_->list[static_cast<std::size_t>(*k)];
  if (same_qualification(last, *now)) return info;
  if (const std::optional<description::StylusTip> measured = machine_.qualified_by_cmmd(tip_id);
      measured && now->qualification && same_qualification(in_force(*measured, ""), *now)) {
    take_on(*now, "machine.qualify while the job was held");
    return info;
  }
  if (!now->qualification && rules_.allow_unqualified) {
    take_on(*now, "nominal, not qualified: allowed by the request (allow_unqualified_tip)");
    return info;
  }
  const std::string details = "the job's touches with " + tip_id + " so far were made with " + describe(last) +
                              "; the machine now reports " + describe(in_force(*now, ""));
  const char* what = last.qualification && !now->qualification ? "vanished" : "changed";
  info = qualify_or_hold(tip_id, "tip " + tip_id + "'s qualification " + what + " since the job began", details, clearance_z);
  if (const description::StylusTip* qualified = info.find_tip(tip_id)) take_on(*qualified, "qualified by the job (requalify)");
  return info;
}

// The job's first touch with this tip: a qualified tip is taken as it is; one never qualified (or
// forgotten by a controller that restarted) only when the request allows it or lets the job qualify it.
description::MachineDescription TipWatch::first_use(description::MachineDescription info, const std::string& tip_id,
                                                    double clearance_z) {
  const description::StylusTip& now = *info.find_tip(tip_id);
  if (now.qualification) {
    add_entry(now, "in force when the job first used it");
    return info;
  }
  if (rules_.allow_unqualified) {
    add_entry(now, "nominal, never qualified: allowed by the request (allow_unqualified_tip)");
    return info;
  }
  info = qualify_or_hold(tip_id, "tip " + tip_id + " is not qualified",
                         "the machine reports " + describe(in_force(now, "")) +
                             " (a controller that restarted forgets its qualifications)",
                         clearance_z);
  if (const description::StylusTip* qualified = info.find_tip(tip_id)) add_entry(*qualified, "qualified by the job (requalify)");
  return info;
}

// A tip fitted by hand sits however the operator seated it: only a qualification made since it was
// asked for says where its ball is.
description::MachineDescription TipWatch::fitted_by_hand(description::MachineDescription info, const std::string& tip_id,
                                                         double clearance_z) {
  const description::StylusTip& now = *info.find_tip(tip_id);
  const bool fresh = now.qualification && now.qualification->time_utc >= record_->fitting_since_utc;
  if (!fresh && !rules_.allow_unqualified)
    info = qualify_or_hold(tip_id, "tip " + tip_id + " was fitted by hand and has not been qualified since",
                           "asked for at " + record_->fitting_since_utc + "; the machine reports " +
                               describe(in_force(now, "")),
                           clearance_z);
  JobQualifications next = *record_;
  next.fitting.reset();
  save(next);
  if (const description::StylusTip* fitted = info.find_tip(tip_id))
    take_on(*fitted, fresh || rules_.requalify ? "fitted by hand, qualified since"
                                               : "fitted by hand, not qualified: allowed by the request (allow_unqualified_tip)");
  return info;
}

description::MachineDescription TipWatch::qualify_or_hold(const std::string& tip_id, const std::string& why,
                                                          const std::string& details, double clearance_z) {
  if (!rules_.requalify)
    throw JobHold(JobState::paused,
                  why + ": qualify it (machine.qualify with tip " + tip_id + ", cmmctl qualify --tip " + tip_id +
                      "), then job.resume; or submit the job with requalify, or with allow_unqualified_tip to measure "
                      "with its nominal radius and offset",
                  JobFault{"Qualification", details});
  spdlog::warn("job {}: {} ({}); qualifying it (requalify)", id_, why, details);
  requalify(tip_id, clearance_z);
  return machine_.cmm().info();
}

void TipWatch::add_entry(const description::StylusTip& tip, const std::string& source) {
  JobQualifications next = record_.value_or(JobQualifications{tip.id, {}, {}, {}});
  QualificationInForce q = in_force(tip, source);
  q.since_utc = hal::utc_now();
  next.list.push_back(std::move(q));
  save(next);
}

// The touches from here on are made, and compensated, with the tip as it is now. Before the
// registration nothing is measured yet, and the new one simply replaces the old.
void TipWatch::take_on(const description::StylusTip& tip, const std::string& source) {
  JobQualifications next = *record_;
  const std::optional<int> first = [&]() -> std::optional<int> {
    for (std::size_t i = 0; i < next.list.size(); ++i)
      if (next.list[i].tip == tip.id) return static_cast<int>(i);
    return std::nullopt;
  }();
  if (!store_.read(id_, JobFile::registration)) {
    std::erase_if(next.list, [&](const QualificationInForce& q) { return q.tip == tip.id; });
  } else if (first) {
    const QualificationInForce& planned = next.list[static_cast<std::size_t>(*first)];
    if (std::abs(tip.ball_radius_mm - planned.ball_radius_mm) > max_radius_change_mm)
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
