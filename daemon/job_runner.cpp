#include "daemon/job_runner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

#include "geometry/atomic_file.hpp"
#include "hal/description/eigen_json.hpp"
#include "daemon/job_planning.hpp"
#include "daemon/job_result.hpp"
#include "daemon/rpc_error.hpp"
#include "daemon/storage_error.hpp"
#include "daemon/touch_journal.hpp"
#include "daemon/touch_motion.hpp"
#include "hal/fault.hpp"
#include "hal/utc_time.hpp"
#include "planner/corner_probing.hpp"
#include "planner/plate_pose.hpp"

#include <spdlog/spdlog.h>

namespace cmm::daemon {

namespace {

// Unwinds a run at a safe point between steps into the state it should stop in.
struct Held {
  JobState state;
  std::string reason;
  std::optional<JobFault> fault = std::nullopt;
};

// A qualification that moves the radius by more than this is no requalification of the tip the job
// was planned for (ten times a qualification's repeatability): the plan is made afresh instead.
constexpr double max_radius_change_mm = 0.01;

description::StylusTip active_tip(const description::MachineDescription& info) {
  if (const description::StylusTip* tip = info.find_tip(info.active_tip)) return *tip;
  throw RpcError(rpc_code::planning_error, "the machine reports no active tip (\"" + info.active_tip + "\")");
}

}  // namespace

struct JobRunner::Registration {
  Eigen::Isometry3d T_M_S = Eigen::Isometry3d::Identity();
  nlohmann::json file;  // registration.json
};

JobRunner::JobRunner(RunEnvironment env, int job_id, JobRequest request, JobControl& control, JobSink sink)
    : env_(env), id_(job_id), request_(std::move(request)), control_(control), sink_(std::move(sink)) {}

void JobRunner::check_stop() const {
  if (control_.shutdown) throw Held{JobState::interrupted, "cmmd stopped during the job"};
  if (control_.cancel) throw Held{JobState::cancelled, "cancelled by the operator"};
  if (control_.operator_stop) throw Held{JobState::paused, "operator stop"};
}

void JobRunner::check_control() const {
  check_stop();
  if (control_.pause) throw Held{JobState::paused, "operator pause"};
}

// One touch, its search line recorded first so that whoever moves next after a stop leaves along it.
hal::TouchResult JobRunner::touch(const planner::Touch& t, std::span<const planner::Motion> motions) {
  env_.machine.enter_touch({t.start, t.direction});
  const hal::TouchResult r = run_motions(env_.machine.cmm(), motions, [this] { check_stop(); });
  env_.machine.left_touch();
  return r;
}

// Up, reset and homed as the run needs; a touch a stop cut short is left the way it came in.
void JobRunner::prepare_machine(bool rehome) {
  env_.machine.bring_up();
  hal::Cmm& cmm = env_.machine.cmm();
  hal::MachineStatus s = cmm.status();
  // The operator asked to go on (job.resume): that is the word a latched abort or a released
  // e-stop waits for (docs/api.md).
  if (s.aborted || s.estop) {
    cmm.reset();
    s = cmm.status();
  }
  // A ball left on a search line it could not leave (a contact, a fault on the way out) must not be
  // driven anywhere else: the job holds until the operator has cleared it.
  if (const std::optional<std::string> stuck = finish_touch_safely())
    throw Held{JobState::paused, "could not leave the touch a stop cut short: " + *stuck +
                                     " (clear the probe by hand, then job.resume)",
               JobFault{"Safety", *stuck}};
  if (const auto line = env_.machine.touch_in_progress(); line && !s.homed)
    // Homing raises z first: from a search line that is at most δ + pre-travel + overtravel off the
    // vertical the ball came down on, which the plan checked.
    spdlog::warn("job {}: homing with the probe possibly on a search line (its position is lost)", id_);
  if (rehome || !s.homed) {
    cmm.home();
    env_.machine.left_touch();
  }
}

JobRunner::Registration JobRunner::measure_plate(double radius_mm) {
  const description::Plate& plate = request_.plate;
  const PlateMeasurement& m = *request_.measure;
  const Eigen::Isometry3d rough = planner::fit_plate_pose(plate, m.ids, m.rough_machine);
  planner::CornerProbingOptions options;
  options.ball_radius_mm = radius_mm;
  const std::vector<planner::Touch> touches = planner::plan_corner_touches(plate, rough, options);
  const description::MachineDescription& d = env_.config.description;
  std::vector<planner::Vec3> centres;
  hal::Vec3 at = env_.machine.cmm().status().position;
  for (std::size_t i = 0; i < touches.size(); ++i) {
    check_control();
    if (env_.machine.connections() != checked_connections_)
      throw Held{JobState::paused, "the machine reconnected while the plate was measured (its tip may have changed): "
                                   "job.resume measures the plate again"};
    sink_.progress({"registering", static_cast<int>(i), static_cast<int>(touches.size()), 0});
    const hal::TouchResult r = touch(touches[i], planner::touch_motions(touches[i], at, d.clearance_z, d));
    at = touches[i].start;
    if (!r.contact)
      throw RpcError(rpc_code::registration_error,
                     "plate touch " + std::to_string(touches[i].id) + " (" + planner::to_string(touches[i].target) +
                         (touches[i].corner > 0 ? ", corner " + std::to_string(touches[i].corner) : std::string()) +
                         ") found nothing: the plate is not where rough_machine puts it",
                     {{"kind", "probing"}});
    centres.push_back(r.centre);
  }
  sink_.progress({"registering", static_cast<int>(touches.size()), static_cast<int>(touches.size()), 0});
  const std::vector<planner::CornerFit> fits = planner::fit_corners(plate, touches, centres, options);
  planner::RegistrationInput input;
  input.source = "job " + std::to_string(id_) + " plate measurement";
  input.plate = plate;
  std::vector<planner::Vec3> measured;
  for (std::size_t i = 0; i < m.ids.size(); ++i) {
    const planner::Vec3 machine = fits.at(static_cast<std::size_t>(m.ids[i] - 1)).position;
    input.corners.push_back({m.ids[i], m.scan[i], machine});
    measured.push_back(machine);
  }
  const Eigen::Isometry3d T_M_P = planner::fit_plate_pose(plate, m.ids, measured);
  input.fiducial_machine = planner::locate_fiducial(plate, T_M_P, touches, centres, options).point;
  const planner::RegistrationResult fit = planner::fit_registration(input, &plate);

  Registration reg;
  reg.T_M_S = fit.T_M_S;
  reg.file = {{"method", "measured"}, {"registration", planner::to_json(fit)}, {"corner_touches", touches.size()}};
  nlohmann::json corners = nlohmann::json::array();
  for (const planner::CornerFit& c : fits)
    corners.push_back({{"id", c.corner}, {"machine", description::vec3_json(c.position)}, {"face_rms_mm", c.face_rms_mm},
                       {"conditioning", c.conditioning}});
  reg.file["measured_corners"] = corners;
  return reg;
}

JobRunner::Registration JobRunner::registration(bool reregister, double radius_mm, const std::string& tip) {
  if (!reregister)
    if (const std::optional<std::string> kept = env_.store.read_file(id_, "registration.json")) {
      Registration reg;
      reg.file = nlohmann::json::parse(*kept);
      reg.T_M_S = description::transform_from_json(reg.file.at("T_M_S"));
      return reg;
    }
  sink_.state(JobState::registering, "", std::nullopt);
  if (reregister) {
    // A new T_M_S makes a new plan whose touch ids need not match the journal's: keep the old
    // touches aside, start the journal and the plan afresh.
    const std::filesystem::path folder = env_.store.folder(id_);
    const std::string stamp = hal::utc_now();
    if (std::filesystem::exists(folder / "touches.jsonl"))  // throws when it cannot: the old touches must not stay
      std::filesystem::rename(folder / "touches.jsonl", folder / ("touches.before-" + stamp + ".jsonl"));
    std::error_code ignored;
    std::filesystem::remove(folder / "plan.json", ignored);
    geometry::sync_folder(folder);
  }
  Registration reg;
  try {
    if (request_.measure) {
      reg = measure_plate(radius_mm);
    } else {
      const planner::RegistrationResult fit = planner::fit_registration(*request_.given, &request_.plate);
      reg.T_M_S = fit.T_M_S;
      reg.file = {{"method", "given"}, {"registration", planner::to_json(fit)}};
    }
  } catch (const planner::RegistrationError& e) {
    nlohmann::json corners = e.corners();
    throw RpcError(rpc_code::registration_error, e.what(), {{"corners", corners}});
  }
  // The plan is made again on every resume; keeping the radius and tip it was first made for keeps
  // its touch ids, and with them the journal, valid even if the tip is qualified again meanwhile.
  reg.file["T_M_S"] = description::transform_json(reg.T_M_S);
  reg.file["radius_mm"] = radius_mm;
  reg.file["tip"] = tip;
  reg.file["time_utc"] = hal::utc_now();
  env_.store.write_file(id_, "registration.json", reg.file.dump(1) + "\n");
  return reg;
}

std::optional<std::string> JobRunner::finish_touch_safely(bool clear_of_part) {
  const std::optional<SearchLine> line = env_.machine.touch_in_progress();
  if (!line && !clear_of_part) return std::nullopt;
  try {
    // A stop dropped the driver to connected; enable it again to move out the way the ball came.
    env_.machine.bring_up();
    const hal::MachineStatus s = env_.machine.cmm().status();
    if (!s.homed || s.aborted || s.estop) return std::nullopt;  // it cannot move now; the next mover leaves the line
    const description::MachineDescription& d = env_.config.description;
    if (!line) {
      // Between touches the ball rests at the last one's search start, below the plane.
      rise_to_clearance(env_.machine.cmm(), d.clearance_z, {0, d.probe_speed_mm_s});
      return std::nullopt;
    }
    leave_touch(env_.machine.cmm(), line->start, line->direction, d.clearance_z, {0, d.probe_speed_mm_s});
    env_.machine.left_touch();
    return std::nullopt;
  } catch (const std::exception& e) {
    spdlog::warn("job {}: could not leave the touch in progress: {}", id_, e.what());
    return std::string(e.what());
  }
}

// Every touch of plan.json in the journal, with the registration kept: nothing is left to measure.
bool JobRunner::probing_complete() const {
  try {
    const std::optional<std::string> plan = env_.store.read_file(id_, "plan.json");
    if (!plan || !env_.store.read_file(id_, "registration.json")) return false;
    std::set<int> made;
    for (const JournalEntry& e : recover_journal(env_.store.folder(id_) / "touches.jsonl").entries) made.insert(e.touch_id);
    const nlohmann::json program = nlohmann::json::parse(*plan).at("program");
    for (const nlohmann::json& t : program)
      if (!made.contains(t.at("id").get<int>())) return false;
    return !program.empty();
  } catch (const std::exception&) {
    return false;  // whatever is wrong with the files, the ordinary run says so
  }
}

// Touches a full disk kept out of the journal, in the order they were made, before anything else
// of this run; each is reported (job.touch) once it is kept.
void JobRunner::journal_unjournaled() {
  if (unjournaled_.empty()) return;
  const std::filesystem::path file = env_.store.folder(id_) / "touches.jsonl";
  std::set<int> kept;
  for (const JournalEntry& e : recover_journal(file).entries) kept.insert(e.touch_id);
  TouchJournal journal(file);
  while (!unjournaled_.empty()) {
    const JournalEntry e = unjournaled_.front();
    if (!kept.contains(e.touch_id)) {
      journal.append(e);
      sink_.touched(e.touch_id, e.result);
    }
    unjournaled_.erase(unjournaled_.begin());
  }
}

void JobRunner::load_qualifications() {
  if (qualifications_) return;
  if (const std::optional<std::string> text = env_.store.read_file(id_, "qualifications.json"))
    qualifications_ = job_qualifications_from_json(nlohmann::json::parse(*text));
}

// Before a run's first touch, and again after the driver reconnected: the job's tip as the machine
// reports it now against the qualification its touches were last made under. Unchanged: on.
// Changed or vanished (a controller that restarted forgets it): the job takes on a qualification
// cmmd itself measured since (machine.qualify during the hold), or with `requalify` measures one
// itself; else it pauses for the operator. `reregister` starts the record afresh, as the journal is.
// Returns the machine's info as it is afterwards.
description::MachineDescription JobRunner::check_qualification(description::MachineDescription info, bool reregister) {
  checked_connections_ = env_.machine.connections();
  const std::filesystem::path folder = env_.store.folder(id_);
  if (reregister && std::filesystem::exists(folder / "qualifications.json")) {
    std::filesystem::rename(folder / "qualifications.json", folder / ("qualifications.before-" + hal::utc_now() + ".json"));
    qualifications_.reset();
  }
  if (!reregister) load_qualifications();
  const std::optional<std::string> kept = reregister ? std::nullopt : env_.store.read_file(id_, "registration.json");
  const std::string tip_id = qualifications_ ? qualifications_->tip
                             : kept           ? nlohmann::json::parse(*kept).value("tip", info.active_tip)
                                              : info.active_tip;
  const description::StylusTip* now = info.find_tip(tip_id);
  if (now == nullptr || tip_id != info.active_tip) return info;  // the tip check before probing holds the job
  if (!qualifications_) {
    const char* source = reregister ? "in force when the job was registered again (reregister)"
                         : kept     ? "in force when cmmd first checked it (the job began before its qualifications "
                                      "were recorded)"
                                    : "in force when the job began";
    JobQualifications first{tip_id, {in_force(*now, source)}};
    first.list.front().since_utc = hal::utc_now();
    env_.store.write_file(id_, "qualifications.json", to_json(first).dump(1) + "\n");
    qualifications_ = std::move(first);
    return info;
  }
  const QualificationInForce& current = qualifications_->list.back();
  if (same_qualification(current, *now)) return info;
  if (const std::optional<description::StylusTip> measured = env_.machine.qualified_by_cmmd(tip_id);
      measured && now->qualification && same_qualification(in_force(*measured, ""), *now)) {
    take_on(*now, "machine.qualify while the job was held");
    return info;
  }
  const std::string details = "the job's touches so far were made with " + describe(current) +
                              "; the machine now reports " + describe(in_force(*now, ""));
  if (request_.requalify) {
    spdlog::warn("job {}: tip {}: {}; qualifying it again (requalify)", id_, tip_id, details);
    requalify(tip_id);
    info = env_.machine.cmm().info();
    if (const description::StylusTip* qualified = info.find_tip(tip_id)) take_on(*qualified, "qualified by the job (requalify)");
    return info;
  }
  const char* what = current.qualification && !now->qualification ? "vanished" : "changed";
  throw Held{JobState::paused,
             "tip " + tip_id + "'s qualification " + what + " since the job began: machine.qualify, then job.resume",
             JobFault{"Qualification", details}};
}

// The touches from here on are made, and compensated, with the tip as it is now.
// Before the registration nothing is measured yet, and the new one simply replaces the old.
void JobRunner::take_on(const description::StylusTip& tip, const std::string& source) {
  JobQualifications next = *qualifications_;
  const QualificationInForce planned = next.list.front();
  if (!env_.store.read_file(id_, "registration.json")) {
    next.list.clear();
  } else if (std::abs(tip.ball_radius_mm - planned.ball_radius_mm) > max_radius_change_mm) {
    throw Held{JobState::paused,
               "tip " + tip.id + "'s radius is now " + describe(in_force(tip, "")) + ", the job was planned for " +
                   describe(planned) + ": not the same tip; job.resume with reregister plans the job afresh",
               JobFault{"Qualification", "radius changed by more than 0.01 mm"}};
  }
  QualificationInForce q = in_force(tip, source);
  q.since_utc = hal::utc_now();
  next.list.push_back(std::move(q));
  env_.store.write_file(id_, "qualifications.json", to_json(next).dump(1) + "\n");
  qualifications_ = std::move(next);
  spdlog::info("job {}: tip {} now {} ({}); the touches from here on are made with it", id_, tip.id,
               describe(qualifications_->list.back()), source);
}

// hal::qualify as machine.qualify does it, from between two touches: up to the clearance plane (the
// plan's, which may lie above the machine's) and across it to above the reference sphere first; the
// qualification's own moves start from there.
void JobRunner::requalify(const std::string& tip_id) {
  hal::Cmm& cmm = env_.machine.cmm();
  const description::MachineDescription& d = env_.config.description;
  double clearance_z = d.clearance_z;
  if (const std::optional<std::string> plan = env_.store.read_file(id_, "plan.json"))
    clearance_z = std::max(clearance_z, nlohmann::json::parse(*plan).value("clearance_z", clearance_z));
  check_stop();
  rise_to_clearance(cmm, clearance_z, {0, d.probe_speed_mm_s});
  check_stop();
  const hal::Vec3 at = cmm.status().position, sphere = cmm.info().reference_sphere.centre;
  cmm.move({hal::Vec3(sphere.x(), sphere.y(), at.z()), 0});
  hal::QualificationOptions options;
  options.before_motion = [this] { check_stop(); };
  const description::TipQualification q = env_.machine.qualify(tip_id, options);
  spdlog::info("job {}: tip {} qualified: r {:.5f} mm, rms {:.5f} mm", id_, tip_id, q.ball_radius_mm, q.residual_rms_mm);
}

void JobRunner::run(bool rehome, bool reregister) {
  const std::string started = hal::utc_now();
  try {
    sink_.state(JobState::planning, "", std::nullopt);
    journal_unjournaled();
    // Planning a large model takes a while: a cancel or a shutdown ends it at its next step.
    const geometry::CancelCheck planning_cancel{[this] { return control_.cancel || control_.shutdown; }};
    const ReferenceModel model = load_reference_model(env_.models.resolve(request_.model), request_,
                                                      env_.config.description.travel_box, planning_cancel);
    check_control();
    // Every planned touch made (the result could not be written): the result is made again from the
    // journal, with no motion at all, so the machine is only asked for its description.
    const bool probed = !reregister && probing_complete();
    if (probed) env_.machine.bring_up();
    else prepare_machine(rehome);
    const double clock0_s = env_.machine.cmm().status().t_s;
    description::MachineDescription info = env_.machine.cmm().info();
    if (probed) load_qualifications();
    else info = check_qualification(std::move(info), reregister);
    const description::StylusTip tip = active_tip(info);
    const Registration reg = registration(reregister, tip.ball_radius_mm, tip.id);
    description::MachineDescription machine = machine_for_job(env_.config.description, info);
    for (description::StylusTip& t : machine.tips)
      if (t.id == reg.file.value("tip", tip.id)) {
        t.ball_radius_mm = reg.file.value("radius_mm", t.ball_radius_mm);
        machine.active_tip = t.id;
      }
    if (!probed && machine.active_tip != info.active_tip)
      throw Held{JobState::paused, "job " + std::to_string(id_) + " was registered with tip " + machine.active_tip +
                                       " but the machine's active tip is " + info.active_tip +
                                       ": select it again, or resume with reregister"};
    check_control();
    const planner::MeasurementPlan plan = plan_job(model, reg.T_M_S, machine, request_, planning_cancel);
    if (!env_.store.read_file(id_, "plan.json"))
      env_.store.write_file(id_, "plan.json",
                            planner::plan_json(model.features, model.inputs, &plan, &machine, reg.file["registration"])
                                    .dump(1) + "\n");

    // Probing: every touch not yet in the journal, in program order.
    sink_.state(JobState::probing, "", std::nullopt);
    const std::filesystem::path journal_file = env_.store.folder(id_) / "touches.jsonl";
    std::map<int, hal::TouchResult> results;
    std::map<int, int> qualification_of;  // touch id → index into qualifications_
    for (const JournalEntry& e : recover_journal(journal_file).entries) {
      results[e.touch_id] = e.result;
      qualification_of[e.touch_id] = e.qualification;
    }
    TouchJournal journal(journal_file);
    std::map<int, double> planned_s;  // by touch; -1 the way home
    for (const planner::Motion& m : plan.program.motions) planned_s[m.touch] += m.time_s;
    double remaining_s = planned_s[-1];
    for (const planner::Touch& t : plan.program.touches)
      if (!results.contains(t.id)) remaining_s += planned_s[t.id];
    const int total = static_cast<int>(plan.program.touches.size());
    const auto t0 = std::chrono::steady_clock::now();
    double planned_done_s = 0;
    auto report = [&] {
      // The plan's estimate for what is left, scaled by how this run has kept to the plan so far.
      const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double pace = planned_done_s > 0 ? wall_s / planned_done_s : 1;
      sink_.progress({"probing", static_cast<int>(results.size()), total, remaining_s * pace});
    };
    report();
    const double clearance = plan.program.clearance_z;
    // The plan's motions, from where the ball is now for the first touch left to make.
    hal::Vec3 at = probed ? hal::Vec3::Zero() : env_.machine.cmm().status().position;
    for (const planner::Touch& t : plan.program.touches) {
      if (results.contains(t.id)) continue;
      check_control();
      if (env_.machine.connections() != checked_connections_)  // the driver reconnected: the tip may have changed
        info = check_qualification(env_.machine.cmm().info(), false);
      const int q = static_cast<int>(qualifications_ ? qualifications_->list.size() - 1 : 0);
      const hal::TouchResult r =
          touch(t, motions_from(at, planner::motions_of(plan.program, t.id), t, clearance, machine));
      at = t.start;
      try {
        journal.append({t.id, r, q});
      } catch (const std::exception&) {
        // The touch is made but not kept (a full disk): it waits here and is journalled first when
        // the job goes on, so it is neither lost nor made twice (unless cmmd stops meanwhile: then
        // the resume makes it again). The job holds, storage full (below).
        unjournaled_.push_back({t.id, r, q});
        throw;
      }
      results[t.id] = r;
      qualification_of[t.id] = q;
      remaining_s -= planned_s[t.id];
      planned_done_s += planned_s[t.id];
      sink_.touched(t.id, r);
      report();
    }
    // Home, as the program ends: a finished job leaves the probe clear of the part.
    if (!probed) {
      const std::span<const planner::Motion> home = planner::home_motions_of(plan.program);
      const std::vector<planner::Motion> way = !home.empty() && (home.front().from - at).norm() <= 1e-3
                                                   ? std::vector<planner::Motion>(home.begin(), home.end())
                                                   : planner::home_motions(at, plan.program.home, clearance, machine);
      run_motions(env_.machine.cmm(), way, [this] { check_stop(); });
    }

    const JobResultInputs inputs{.model = model,
                                 .plan = plan,
                                 .machine = machine,
                                 .request = request_,
                                 .config = env_.config,
                                 .T_M_S = reg.T_M_S,
                                 .registration = reg.file,
                                 .touches = results,
                                 .qualifications = qualifications_ ? &*qualifications_ : nullptr,
                                 .touch_qualification = qualification_of,
                                 .tip = tip,
                                 .machine_time_s = env_.machine.cmm().status().t_s - clock0_s,
                                 .version = env_.version,
                                 .started_utc = started,
                                 .finished_utc = hal::utc_now()};
    const std::string summary = write_job_result(env_.store, id_, inputs);
    sink_.state(JobState::done, summary, std::nullopt);
  } catch (const geometry::Cancelled&) {
    // Planning heard the cancel or the shutdown: the same ending as a Held from check_control.
    if (control_.shutdown) {
      sink_.state(JobState::interrupted, "cmmd stopped during the job", std::nullopt);
    } else {
      finish_touch_safely(true);
      sink_.state(JobState::cancelled, "cancelled by the operator", std::nullopt);
    }
  } catch (const Held& held) {
    // A cancel ends the job, so its touch is left now; a stop or a shutdown means no more motion:
    // the recorded search line waits for the next mover.
    if (held.state == JobState::cancelled) finish_touch_safely(true);
    sink_.state(held.state, held.reason, held.fault);
  } catch (const hal::Fault& fault) {
    // A stop the operator or cmmd asked for surfaces as the driver's Aborted; say why it came.
    if (control_.cancel) {
      finish_touch_safely(true);
      sink_.state(JobState::cancelled, "cancelled by the operator", std::nullopt);
    } else if (control_.shutdown) {
      sink_.state(JobState::interrupted, "cmmd stopped during the job", std::nullopt);
    } else {
      const std::string reason = control_.operator_stop ? "operator stop" : std::string("machine fault: ") + fault.what();
      sink_.state(JobState::paused, reason, JobFault{hal::to_string(fault.kind()), fault.what()});
    }
  } catch (const RpcError& e) {
    sink_.state(JobState::failed, e.what(), JobFault{"Job", e.what()});
  } catch (const hal::StateError& e) {
    sink_.state(JobState::paused, std::string("machine not ready: ") + e.what(), JobFault{"State", e.what()});
  } catch (const std::exception& e) {
    // A file of the job that cannot be written (a full disk) holds the job: what it measured is
    // kept, and job.resume goes on once the operator has made room.
    if (const auto failure = storage_failure(e))
      sink_.state(JobState::paused, failure->hold_reason(), JobFault{failure->fault_kind(), e.what()});
    else
      sink_.state(JobState::failed, e.what(), JobFault{"Internal", e.what()});
  }
}

}  // namespace cmm::daemon
