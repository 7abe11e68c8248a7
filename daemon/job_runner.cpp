// The stages of a job's run; see job_runner.hpp.
#include "daemon/job_runner.hpp"

#include <algorithm>
#include <chrono>
#include <set>

#include <spdlog/spdlog.h>

#include "daemon/job_result.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/touch_motion.hpp"
#include "hal/fault.hpp"
#include "hal/utc_time.hpp"
#include "planner/corner_probing.hpp"
#include "planner/number_text.hpp"
#include "planner/plan_json.hpp"
#include "planner/plate_pose.hpp"
#include "planner/registration.hpp"

namespace cmm::daemon {

namespace {

description::StylusTip tip_of(const description::MachineDescription& info, const std::string& id) {
  if (const description::StylusTip* tip = info.find_tip(id)) return *tip;
  throw RpcError(rpc_code::planning_error, "the machine has no tip \"" + id + "\"");
}

}  // namespace

JobRunner::JobRunner(RunEnvironment env, int job_id, JobRequest request, JobControl& control, JobSink sink)
    : env_(env),
      id_(job_id),
      request_(std::move(request)),
      control_(control),
      sink_(std::move(sink)),
      tip_(env_.machine, env_.store, job_id, TipRules{request_.requalify, request_.allow_unqualified_tip},
           [this] { check_stop(); }) {}

void JobRunner::run(bool rehome, bool reregister) {
  const std::string started = hal::utc_now();
  try {
    sink_.state(JobState::planning, "", std::nullopt);
    journal_unjournaled();
    const ReferenceModel model = load_model();
    check_control();
    // Every planned touch made (the result could not be written): the result is made again from the
    // journal, with no motion at all, so the machine is only asked for its description.
    const bool probed = !reregister && probing_complete();
    if (probed) env_.machine.bring_up();
    else prepare_machine(rehome);
    const double clock0_s = env_.machine.cmm().status().t_s;
    const std::optional<JobRegistration> kept = reregister ? std::nullopt : kept_registration();
    const std::vector<std::string> tips = kept ? planned_tip_ids(*kept) : tips_for_registration(env_.machine.cmm().info());
    const description::MachineDescription info = check_tip(reregister, probed, kept.has_value(), tips);
    const JobRegistration registration = register_part(reregister, tips, info);
    const description::MachineDescription machine = machine_for_plan(info, registration);
    check_control();
    const planner::MeasurementPlan plan = this->plan(model, registration, machine);
    const Touches touches = probe(plan, machine, probed);
    const JobResultInputs inputs{.model = model,
                                 .plan = plan,
                                 .machine = machine,
                                 .request = request_,
                                 .config = env_.config,
                                 .registration = registration,
                                 .touches = touches.results,
                                 .qualifications = tip_.qualifications(),
                                 .touch_qualification = touches.qualification_of,
                                 .tip = tip_of(machine, registration.tip),
                                 .machine_time_s = env_.machine.cmm().status().t_s - clock0_s,
                                 .probing_time_s = touches.probing_time_s,
                                 .version = env_.version,
                                 .reference_mesh = reference_mesh_,
                                 .started_utc = started,
                                 .finished_utc = hal::utc_now(),
                                 .models = &env_.models};
    sink_.state(JobState::done, write_job_result(env_.store, id_, inputs), std::nullopt);
  } catch (...) {
    end(ending_of(std::current_exception(), control_));
  }
}

// A cancel ends the job, so its touch is left now; a stop or a shutdown means no more motion: the
// recorded search line waits for the next mover.
void JobRunner::end(const JobEnding& ending) {
  if (ending.state == JobState::cancelled) finish_touch_safely(true);
  sink_.state(ending.state, ending.reason, ending.fault);
}

void JobRunner::check_stop() const {
  if (control_.shutdown) throw JobHold(JobState::interrupted, "cmmd stopped during the job");
  if (control_.cancel) throw JobHold(JobState::cancelled, "cancelled by the operator");
  if (control_.operator_stop) throw JobHold(JobState::paused, "operator stop");
}

void JobRunner::check_control() const {
  check_stop();
  if (control_.pause) throw JobHold(JobState::paused, "operator pause");
}

// --- model

// Planning a large model (or meshing a scan) takes a while: a cancel or a shutdown ends it at its next
// step. The first run stores the mesh it planned on; every later run plans on that (job_reference.hpp).
ReferenceModel JobRunner::load_model() {
  const geometry::CancelCheck cancel{[this] { return control_.cancel || control_.shutdown; }};
  JobReference reference =
      job_reference(env_.store, id_, env_.models, request_, env_.config.description.travel_box, cancel);
  reference_mesh_ = std::move(reference.provenance);
  return std::move(reference.model);
}

// --- machine

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
    throw JobHold(JobState::paused,
                  "could not leave the touch a stop cut short: " + *stuck + " (clear the probe by hand, then job.resume)",
                  JobFault{"Safety", *stuck});
  if (const auto line = env_.machine.touch_in_progress(); line && !s.homed)
    // Homing raises z first: from a search line that is at most δ + pre-travel + overtravel off the
    // vertical the ball came down on, which the plan checked.
    spdlog::warn("job {}: homing with the probe possibly on a search line (its position is lost)", id_);
  if (rehome || !s.homed) {
    cmm.home();
    env_.machine.left_touch();
  }
}

std::optional<std::string> JobRunner::finish_touch_safely(bool clear_of_part) {
  const std::optional<SearchLine> line = env_.machine.touch_in_progress();
  if (!line && !clear_of_part) return std::nullopt;
  try {
    // A stop dropped the driver to connected; enable it again to move out the way the ball came.
    env_.machine.bring_up();
    const hal::MachineStatus s = env_.machine.cmm().status();
    if (!s.homed || s.aborted || s.estop) return std::nullopt;  // it cannot move now; the next mover leaves the line
    const TouchSpeeds speeds{0, env_.config.description.probe_speed_mm_s};
    if (!line) {
      // Between touches the ball rests at the last one's search start, below the plane.
      rise_to_clearance(env_.machine.cmm(), clearance_z(), speeds);
      return std::nullopt;
    }
    leave_touch(env_.machine.cmm(), line->start, line->direction, clearance_z(), speeds);
    env_.machine.left_touch();
    return std::nullopt;
  } catch (const std::exception& e) {
    spdlog::warn("job {}: could not leave the touch in progress: {}", id_, e.what());
    return std::string(e.what());
  }
}

double JobRunner::clearance_z() const {
  double z = env_.config.description.clearance_z;
  try {
    if (const std::optional<std::string> plan = env_.store.read(id_, JobFile::plan))
      z = std::max(z, planner::plan_summary_from_json(nlohmann::json::parse(*plan)).clearance_z);
  } catch (const std::exception& e) {
    spdlog::warn("job {}: {} unreadable ({}); the machine's clearance plane is used", id_,
                 env_.store.path(id_, JobFile::plan).string(), e.what());
  }
  return z;
}

// --- tip

std::vector<std::string> JobRunner::planned_tip_ids(const JobRegistration& registration) {
  std::vector<std::string> ids;
  for (const PlannedTip& t : registration.tips) ids.push_back(t.id);
  return ids;
}

// The tips a new registration plans with (daemon::job_tips). A tip left out is said in the log; the
// features only it could reach stay unmeasured, and the verdict says so.
std::vector<std::string> JobRunner::tips_for_registration(const description::MachineDescription& info) const {
  std::vector<std::string> left_out;
  std::vector<std::string> tips = job_tips(request_, env_.config.description, info, &left_out);
  for (const std::string& line : left_out) spdlog::info("job {}: {}", id_, line);
  return tips;
}

// Before a registration, the primary tip is made active and checked; after one, the active tip is
// checked when it is one of the job's (the probing changes to the others as the program asks).
description::MachineDescription JobRunner::check_tip(bool reregister, bool probed, bool registered,
                                                     const std::vector<std::string>& tips) {
  description::MachineDescription info = env_.machine.cmm().info();
  if (probed) {
    tip_.load();
    return info;
  }
  if (!registered) return use_tip(tips.front(), reregister);
  if (std::find(tips.begin(), tips.end(), info.active_tip) == tips.end()) {
    tip_.load();
    return info;
  }
  return tip_.check(std::move(info), false, clearance_z());
}

// Makes `id` the active tip (up to the clearance plane first) and checks it. A machine without a tool
// changer holds the job for the operator to fit it; the run after the resume selects it.
description::MachineDescription JobRunner::use_tip(const std::string& id, bool reregister) {
  hal::Cmm& cmm = env_.machine.cmm();
  description::MachineDescription info = cmm.info();
  if (info.active_tip != id) {
    tip_of(info, id);
    check_stop();
    rise_to_clearance(cmm, planner::tip_change_z(info, id, clearance_z()), {});
    if (!info.tool_changer && tip_.fitting() != id) {
      tip_.ask_fitting(id);
      throw JobHold(JobState::paused,
                    "fit tip " + id + " on the probe (this machine has no tool changer), then job.resume; the tip is "
                    "qualified again before its first touch",
                    JobFault{"TipChange", "the job's next touches are made with tip " + id + "; tip " + info.active_tip +
                                              " is fitted"});
    }
    check_stop();
    cmm.select_tip(id);
    TouchJournal(env_.store.path(id_, JobFile::touches)).append(TipChangeEntry{id, hal::utc_now()});
    spdlog::info("job {}: tip {} {}", id_, id, info.tool_changer ? "selected" : "fitted by hand");
    info = cmm.info();
  }
  return tip_.check(std::move(info), reregister, clearance_z());
}

// --- registration

std::optional<JobRegistration> JobRunner::kept_registration() const {
  const std::optional<std::string> text = env_.store.read(id_, JobFile::registration);
  if (!text) return std::nullopt;
  return job_registration_from_json(nlohmann::json::parse(*text));
}

JobRegistration JobRunner::register_part(bool reregister, const std::vector<std::string>& tips,
                                         const description::MachineDescription& info) {
  if (!reregister)
    if (std::optional<JobRegistration> kept = kept_registration()) return *kept;
  const description::StylusTip tip = tip_of(info, tips.front());
  sink_.state(JobState::registering, "", std::nullopt);
  if (reregister) {
    // A new T_M_S makes a new plan whose touch ids need not match the journal's: the old touches are
    // kept aside, the journal and the plan start afresh.
    env_.store.set_aside(id_, JobFile::touches);
    env_.store.remove(id_, JobFile::plan);
  }
  JobRegistration registration;
  try {
    if (request_.measure) {
      registration = measure_plate(tip.ball_radius_mm);
    } else {
      const planner::RegistrationResult fit = planner::fit_registration(*request_.given, &request_.plate);
      registration.method = JobRegistration::Method::given;
      registration.T_M_S = fit.T_M_S;
      registration.fit = planner::to_json(fit);
    }
  } catch (const planner::RegistrationError& e) {
    nlohmann::json corners = e.corners();
    throw RpcError(rpc_code::registration_error, e.what(), {{"corners", corners}});
  }
  registration.radius_mm = tip.ball_radius_mm;
  registration.tip = tip.id;
  for (const std::string& id : tips) registration.tips.push_back({id, tip_of(info, id).ball_radius_mm});
  registration.time_utc = hal::utc_now();
  env_.store.write(id_, JobFile::registration, to_json(registration).dump(1) + "\n");
  return registration;
}

JobRegistration JobRunner::measure_plate(double radius_mm) {
  const description::Plate& plate = request_.plate;
  const PlateMeasurement& m = *request_.measure;
  const description::MachineDescription& d = env_.config.description;
  planner::CornerProbingOptions options;
  options.ball_radius_mm = radius_mm;
  const std::vector<planner::Touch> touches =
      planner::plan_corner_touches(plate, planner::fit_plate_pose(plate, m.ids, m.rough_machine), options);
  // A touch that finds nothing (or meets the plate early) names its corner, and the rough corner the
  // plate's shape agrees with least: one corner taught off tilts the fitted pose, so another
  // corner's touch may be the first to miss.
  const auto plate_touch_failed = [&](std::size_t i, const std::string& what) {
    const planner::Touch& t = touches[i];
    std::vector<Eigen::Vector3d> nominal;
    for (int id : m.ids) nominal.push_back(plate.corner(id));
    const planner::RigidFit rough = planner::fit_rigid(nominal, m.rough_machine);
    const auto worst = static_cast<std::size_t>(
        std::max_element(rough.residual_norms.begin(), rough.residual_norms.end()) - rough.residual_norms.begin());
    const std::string whose = t.target == planner::TouchTarget::plate_face ? "corner " + std::to_string(t.corner)
                              : t.corner > 0 ? "the fiducial at corner " + std::to_string(t.corner)
                                             : std::string("the fiducial");
    return "plate touch " + std::to_string(i + 1) + " of " + std::to_string(touches.size()) + " (" + whose + ", face " +
           std::to_string(t.face) + ") " + what + ": " +
           (i == 0 ? "the very first plate touch, so the rough machine positions (rough_machine) or the plate "
                     "description may be wrong"
                   : whose + " is not where rough_machine puts the plate") +
           "; of the rough corners, corner " + std::to_string(m.ids[worst]) + " agrees least with the plate's shape (" +
           planner::fixed(rough.residual_norms[worst], 1) + " mm off the others' fit): teach it again";
  };
  std::vector<Eigen::Vector3d> centres;
  hal::Vec3 at = env_.machine.cmm().status().position;
  for (std::size_t i = 0; i < touches.size(); ++i) {
    check_control();
    if (tip_.reconnected())
      throw JobHold(JobState::paused, "the machine reconnected while the plate was measured (its tip may have changed): "
                                      "job.resume measures the plate again");
    sink_.progress({"registering", static_cast<int>(i), static_cast<int>(touches.size()), 0});
    // The same touch sequence as the job's, with the machine's clearance plane.
    hal::TouchResult r;
    try {
      r = touch(touches[i], planner::touch_motions(touches[i], at, d.clearance_z, d));
    } catch (const hal::Fault& f) {
      // Met the plate before the touch (EarlyTrigger), or a search or target off the travel: the
      // machine's fault, its kind kept, said in the registration's terms.
      if (f.kind() != hal::FaultKind::early_trigger && f.kind() != hal::FaultKind::no_contact &&
          f.kind() != hal::FaultKind::soft_limit)
        throw;
      throw hal::Fault(f.kind(), plate_touch_failed(i, std::string("failed (") + hal::to_string(f.kind()) + ": " + f.what() + ")"));
    }
    at = touches[i].start;
    if (!r.contact) {
      const planner::Touch& t = touches[i];
      throw RpcError(rpc_code::registration_error, plate_touch_failed(i, "found nothing"),
                     {{"kind", "probing"}, {"corners", t.target == planner::TouchTarget::plate_face
                                                           ? nlohmann::json::array({t.corner}) : nlohmann::json::array()}});
    }
    centres.push_back(r.centre);
  }
  sink_.progress({"registering", static_cast<int>(touches.size()), static_cast<int>(touches.size()), 0});
  const std::vector<planner::CornerFit> fits = planner::fit_corners(plate, touches, centres, options);
  planner::RegistrationInput input;
  input.source = "job " + std::to_string(id_) + " plate measurement";
  input.plate = plate;
  std::vector<Eigen::Vector3d> measured;
  for (std::size_t i = 0; i < m.ids.size(); ++i) {
    const Eigen::Vector3d machine = fits.at(static_cast<std::size_t>(m.ids[i] - 1)).position;
    input.corners.push_back({m.ids[i], m.scan[i], machine});
    measured.push_back(machine);
  }
  const Eigen::Isometry3d T_M_P = planner::fit_plate_pose(plate, m.ids, measured);
  input.fiducial_machine = planner::locate_fiducial(plate, T_M_P, touches, centres, options).point;
  const planner::RegistrationResult fit = planner::fit_registration(input, &plate);

  JobRegistration registration;
  registration.method = JobRegistration::Method::measured;
  registration.T_M_S = fit.T_M_S;
  registration.fit = planner::to_json(fit);
  registration.corner_touches = static_cast<int>(touches.size());
  for (const planner::CornerFit& c : fits)
    registration.measured_corners.push_back({c.corner, c.position, c.face_rms_mm, c.conditioning});
  return registration;
}

// --- plan

// The configured description with the machine's tips, each of the job's at the radius the plan was
// first made for and the primary active: the same plan, touch ids and all, on every resume.
description::MachineDescription JobRunner::machine_for_plan(const description::MachineDescription& info,
                                                            const JobRegistration& registration) const {
  description::MachineDescription machine = machine_for_job(env_.config.description, info);
  for (description::StylusTip& t : machine.tips)
    for (const PlannedTip& p : registration.tips)
      if (t.id == p.id) t.ball_radius_mm = p.radius_mm;
  machine.active_tip = registration.tip;
  return machine;
}

planner::MeasurementPlan JobRunner::plan(const ReferenceModel& model, const JobRegistration& registration,
                                         const description::MachineDescription& machine) {
  const geometry::CancelCheck cancel{[this] { return control_.cancel || control_.shutdown; }};
  planner::MeasurementPlan plan = plan_job(model, registration.T_M_S, machine, cancel, planned_tip_ids(registration));
  if (!env_.store.read(id_, JobFile::plan)) {
    nlohmann::json file = planner::plan_json(model.features, model.inputs, &plan, &machine, registration.fit);
    file["model"]["reference_mesh"] = reference_mesh_;
    env_.store.write(id_, JobFile::plan, file.dump(1) + "\n");
  }
  return plan;
}

// Every touch of plan.json in the journal, with the registration kept: nothing is left to measure.
bool JobRunner::probing_complete() const {
  try {
    const std::optional<std::string> plan = env_.store.read(id_, JobFile::plan);
    if (!plan || !env_.store.read(id_, JobFile::registration)) return false;
    std::set<int> made;
    for (const JournalEntry& e : recover_journal(env_.store.path(id_, JobFile::touches)).entries) made.insert(e.touch_id);
    const std::vector<int> planned = planner::plan_summary_from_json(nlohmann::json::parse(*plan)).touch_ids;
    return !planned.empty() && std::all_of(planned.begin(), planned.end(), [&](int id) { return made.contains(id); });
  } catch (const std::exception&) {
    return false;  // whatever is wrong with the files, the ordinary run says so
  }
}

// --- probing

// One touch, its search line recorded first so that whoever moves next after a stop leaves along it.
// A stop may end it between motions until the probe has touched; then the result is kept before the
// way back to the start, so that a stop, a shutdown or a fault on that way loses nothing, and no
// check stops it there.
hal::TouchResult JobRunner::touch(const planner::Touch& t, std::span<const planner::Motion> motions,
                                  const std::function<void(const hal::TouchResult&)>& keep) {
  const auto is_probe = [](const planner::Motion& m) { return m.kind == planner::MotionKind::probe; };
  auto back = std::find_if(motions.begin(), motions.end(), is_probe);
  if (back == motions.end()) throw std::logic_error("touch " + std::to_string(t.id) + " has no probe motion");
  ++back;
  hal::Cmm& cmm = env_.machine.cmm();
  env_.machine.enter_touch({t.start, t.direction});
  const hal::TouchResult r = run_motions(cmm, {motions.begin(), back}, [this] { check_stop(); });
  if (keep) keep(r);
  run_motions(cmm, {back, motions.end()}, {});
  env_.machine.left_touch();
  return r;
}

// Touches a full disk kept out of the journal, in the order they were made, before anything else
// of this run; each is reported (job.touch) once it is kept.
void JobRunner::journal_unjournaled() {
  if (unjournaled_.empty()) return;
  const std::filesystem::path file = env_.store.path(id_, JobFile::touches);
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

// Every touch not yet in the journal, in program order, as the plan's motions (from where the ball
// is for the first of them), and then home.
JobRunner::Touches JobRunner::probe(const planner::MeasurementPlan& plan, const description::MachineDescription& machine,
                                    bool probed) {
  const planner::MoveProgram& program = plan.program;
  Touches touches;
  const std::filesystem::path journal_file = env_.store.path(id_, JobFile::touches);
  for (const JournalEntry& e : recover_journal(journal_file).entries) {
    touches.results[e.touch_id] = e.result;
    touches.qualification_of[e.touch_id] = e.qualification;
  }
  sink_.state(JobState::probing, "", std::nullopt);
  if (probed) return touches;
  TouchJournal journal(journal_file);

  std::map<int, double> planned_s;  // by touch; -1 the way home
  for (const planner::Motion& m : program.motions) planned_s[m.touch] += m.time_s;
  double remaining_s = planned_s[-1];
  for (const planner::Touch& t : program.touches)
    if (!touches.results.contains(t.id)) remaining_s += planned_s[t.id];
  const int total = static_cast<int>(program.touches.size());
  const auto t0 = std::chrono::steady_clock::now();
  double planned_done_s = 0;
  auto report = [&] {
    // The plan's estimate for what is left, scaled by how this run has kept to the plan so far.
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double pace = planned_done_s > 0 ? wall_s / planned_done_s : 1;
    sink_.progress({"probing", static_cast<int>(touches.results.size()), total, remaining_s * pace});
  };
  report();

  hal::Cmm& cmm = env_.machine.cmm();
  const double clock0_s = cmm.status().t_s;
  hal::Vec3 at = cmm.status().position;
  std::string active = cmm.info().active_tip;
  for (const planner::Touch& t : program.touches) {
    if (touches.results.contains(t.id)) continue;
    check_control();
    // A tip change the program asks for, or a reconnect (the controller may have restarted with
    // another tip, or forgotten a qualification): the tip is made active and checked.
    const std::string& tip = t.tip.empty() ? machine.active_tip : t.tip;
    if (tip != active || tip_.reconnected()) {
      active = use_tip(tip, false).active_tip;
      at = cmm.status().position;  // a change or a requalification moved the ball
    }
    const int q = tip_.current();
    const auto keep = [&](const hal::TouchResult& r) {
      try {
        journal.append({t.id, r, q});
      } catch (const std::exception&) {
        // The touch is made but not kept (a full disk): it waits here and is journalled first when
        // the job goes on, so it is neither lost nor made twice (unless cmmd stops meanwhile: then
        // the resume makes it again). The job holds, storage full, the ball on the search line.
        unjournaled_.push_back({t.id, r, q});
        throw;
      }
      touches.results[t.id] = r;
      touches.qualification_of[t.id] = q;
      remaining_s -= planned_s[t.id];
      planned_done_s += planned_s[t.id];
      sink_.touched(t.id, r);
      report();
    };
    touch(t, motions_from(at, planner::motions_of(program, t.id), t, program.clearance_z, machine), keep);
    at = t.start;
  }
  // Home, as the program ends: a finished job leaves the probe clear of the part.
  const std::span<const planner::Motion> home = planner::home_motions_of(program);
  const std::vector<planner::Motion> way =
      !home.empty() && (home.front().from - at).norm() <= 1e-3
          ? std::vector<planner::Motion>(home.begin(), home.end())
          : planner::home_motions(at, program.home, program.clearance_z, machine);
  run_motions(cmm, way, [this] { check_stop(); });
  touches.probing_time_s = cmm.status().t_s - clock0_s;
  return touches;
}

}  // namespace cmm::daemon
