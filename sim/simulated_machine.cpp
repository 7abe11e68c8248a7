// The simulated machine: every motion is one or more straight segments of the reference point,
// each checked against the scene, the clock, the e-stop input and stop/abort requests.
#include "sim/simulated_machine.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "geometry/analytic_parts.hpp"
#include "geometry/mesh_io.hpp"
#include "sim/plate_mesh.hpp"

namespace cmm::sim {

namespace {
std::string text(const Vec3& p) {
  std::ostringstream out;
  out.precision(4);
  out << std::fixed << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return out.str();
}

// Marks the machine busy for one motion call, however the call ends; at the end no stop request
// outlives its command, so a stop that came too late cannot stop the next one.
class Busy {
 public:
  Busy(bool& busy, bool& accepted, bool& stop_request) : busy_(busy), accepted_(accepted), stop_request_(stop_request) {
    busy_ = true;
  }
  ~Busy() { busy_ = accepted_ = stop_request_ = false; }
  Busy(const Busy&) = delete;
  Busy& operator=(const Busy&) = delete;

 private:
  bool &busy_, &accepted_, &stop_request_;
};

geometry::TriangleMesh part_mesh(const PartSource& part) {
  if (!part.mesh_file.empty()) {
    geometry::TriangleMesh mesh = geometry::read_mesh(part.mesh_file);
    mesh.vertices *= part.scale;
    return mesh;
  }
  return geometry::make_analytic_part(part.analytic, part.edge_length_mm).mesh;
}
}  // namespace

Scene build_scene(const SimConfig& config) {
  Scene scene;
  scene.T_M_P = config.T_M_P;
  scene.T_M_Part = config.T_M_P * config.T_P_Part;
  scene.part = transformed(part_mesh(config.part), scene.T_M_Part);
  scene.plate = transformed(plate_mesh(config.plate), config.T_M_P);
  scene.sphere_centre = config.machine.reference_sphere.centre;
  scene.sphere_radius = config.machine.reference_sphere.radius_mm;
  return scene;
}

SimulatedMachine::SimulatedMachine(const SimConfig& config)
    : config_(config), scene_(build_scene(config)), contact_(std::make_unique<SceneContact>(scene_)), rng_(config.seed) {
  for (const auto& t : config_.machine.tips) {
    Tip tip;
    tip.info = t;
    tip.true_radius = t.ball_radius_mm;
    tip.true_offset = t.offset;
    if (auto it = config_.true_tips.find(t.id); it != config_.true_tips.end()) {
      if (it->second.ball_radius_mm > 0) tip.true_radius = it->second.ball_radius_mm;
      tip.true_offset += it->second.offset;
    }
    if (t.id == config_.machine.active_tip) active_ = tips_.size();
    tips_.push_back(tip);
  }
  ref_ = config_.power_on_position - active().info.offset;
}

const SimulatedMachine::Tip& SimulatedMachine::active() const { return tips_.at(active_); }

std::size_t SimulatedMachine::tip_index(const std::string& id) const {
  for (std::size_t i = 0; i < tips_.size(); ++i)
    if (tips_[i].info.id == id) return i;
  throw std::invalid_argument("no tip \"" + id + "\" on the simulated machine");
}

double SimulatedMachine::true_ball_radius(const std::string& id) const { return tips_[tip_index(id)].true_radius; }
Vec3 SimulatedMachine::true_offset(const std::string& id) const { return tips_[tip_index(id)].true_offset; }

description::MachineDescription SimulatedMachine::info() const {
  std::lock_guard lock(mutex_);
  description::MachineDescription info = config_.machine;
  info.name = "simulated CMM (" + (config_.part.mesh_file.empty() ? config_.part.analytic : config_.part.mesh_file) + ")";
  info.tips.clear();
  for (const auto& t : tips_) info.tips.push_back(t.info);
  info.active_tip = active().info.id;
  return info;
}

hal::MachineStatus SimulatedMachine::status() const {
  std::lock_guard lock(mutex_);
  hal::MachineStatus s;
  s.homed = homed_;
  s.moving = moving_;
  s.estop = estop_;
  s.aborted = aborted_;
  s.fault = fault_;
  s.fault_message = fault_message_;
  s.tip_id = active().info.id;
  Vec3 ref = ref_;
  s.t_s = clock_s_;
  if (moving_ && config_.time_scale > 0) {
    double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - seg_wall_start_).count() *
               config_.time_scale;
    ref = seg_from_ + seg_dir_ * seg_profile_.position_at(t);
    s.t_s += std::min(t, seg_profile_.duration());
  }
  s.position = reported(ref);
  return s;
}

void SimulatedMachine::fail(hal::FaultKind kind, const std::string& message) {
  fault_ = kind;
  fault_message_ = message;
  hal::throw_fault(kind, message);
}

void SimulatedMachine::check_can_move(bool need_homed) const {
  if (busy_) throw hal::StateError("the simulated machine is already running a motion");
  if (estop_) hal::throw_fault(hal::FaultKind::estop, "the e-stop is active; reset() after releasing it");
  if (aborted_) hal::throw_fault(hal::FaultKind::aborted, "abort is latched; reset() first");
  if (need_homed && !homed_) hal::throw_fault(hal::FaultKind::not_homed, "home() first");
}

void SimulatedMachine::check_in_box(const Vec3& ball, const char* what) const {
  if (!ball.allFinite()) throw std::invalid_argument(std::string(what) + " is not finite");
  if (!config_.machine.travel_box.contains(ball, 1e-9))
    hal::throw_fault(hal::FaultKind::soft_limit, std::string(what) + " " + text(ball) + " is outside the travel box " +
                                                     text(config_.machine.travel_box.min) + " – " +
                                                     text(config_.machine.travel_box.max));
}

void SimulatedMachine::begin_command() {
  ++commands_;
  const int first = config_.faults.spurious_trigger_at_motion;
  spurious_pending_ = first > 0 && commands_ >= first && commands_ - first < config_.faults.spurious_trigger_count;
  abort_request_ = false;  // abort() latched aborted_ too, which check_can_move() has seen
}

double SimulatedMachine::gaussian() {
  // Box–Muller on the raw generator, so the draws are the same on every standard library.
  constexpr double two_pi = 2 * std::numbers::pi;
  double u1 = (static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53;
  double u2 = static_cast<double>(rng_() >> 11) * 0x1.0p-53;
  return std::sqrt(-2 * std::log(u1)) * std::cos(two_pi * u2);
}

SimulatedMachine::Outcome SimulatedMachine::run(std::unique_lock<std::mutex>& lock, const Vec3& to_ref, double speed) {
  Outcome out;
  // A stop or abort that came between the segments of one command ends it before the next.
  if (abort_request_) fail(hal::FaultKind::aborted, "aborted before the next segment at " + text(reported(ref_)));
  if (stop_request_) fail(hal::FaultKind::aborted, "stopped at " + text(reported(ref_)) + " by stop()");
  const Vec3 from = ref_;
  const double distance = (to_ref - from).norm();
  if (distance == 0) return out;
  const Vec3 u = (to_ref - from) / distance;
  const auto& m = config_.machine;
  const double v = std::min(speed > 0 ? speed : m.max_speed_mm_s, m.max_speed_mm_s);
  const TrapezoidProfile profile = make_profile(distance, path_limit(u, v, config_.axis_max_speed_mm_s),
                                                path_limit(u, m.max_accel_mm_s2, config_.axis_max_accel_mm_s2));

  // Events along the segment, by machine time from its start.
  double end_s = distance, end_t = profile.duration();
  enum class Event { none, trigger, estop } event = Event::none;
  const Tip& t = active();
  if (spurious_pending_) {
    spurious_pending_ = false;
    end_s = 0, end_t = 0, event = Event::trigger, out.spurious = true;
  } else if (auto hit = contact_->first_hit(from + t.true_offset, u, distance, t.true_radius)) {
    end_s = hit->travel, end_t = profile.time_at(hit->travel), event = Event::trigger;
  }
  if (!estop_fired_ && config_.faults.estop_at_s >= 0 && clock_s_ + end_t >= config_.faults.estop_at_s) {
    end_t = std::max(0.0, config_.faults.estop_at_s - clock_s_);
    end_s = profile.position_at(end_t);
    event = Event::estop;
  }

  bool stopped = false, aborted = false;
  if (config_.time_scale > 0) {
    moving_ = true;
    seg_from_ = from, seg_dir_ = u, seg_profile_ = profile;
    seg_wall_start_ = std::chrono::steady_clock::now();
    auto wall = [&](double machine_s) {
      return seg_wall_start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::duration<double>(machine_s / config_.time_scale));
    };
    wake_.wait_until(lock, wall(end_t), [&] { return stop_request_ || abort_request_; });
    double now = std::chrono::duration<double>(std::chrono::steady_clock::now() - seg_wall_start_).count() *
                 config_.time_scale;
    if (abort_request_ && now < end_t) {
      aborted = true, event = Event::none;
      end_t = now, end_s = profile.position_at(now);
    } else if (stop_request_ && now < end_t && profile.stop_position(now) < end_s) {
      stopped = true, event = Event::none;
      end_s = profile.stop_position(now), end_t = profile.stop_time(now);
      wake_.wait_until(lock, wall(end_t));
    }
    moving_ = false;
  }
  ref_ = from + u * end_s;
  clock_s_ += end_t;
  out.travel = end_s;
  out.triggered = event == Event::trigger;

  if (event == Event::estop) {
    estop_ = estop_fired_ = true;
    homed_ = false;  // servo power is cut: the position is no longer trusted
    fail(hal::FaultKind::estop, "the machine's e-stop input went active at t = " + std::to_string(clock_s_) + " s");
  }
  if (aborted) {
    aborted_ = true;
    homed_ = false;  // an axis stopped dead may have lost its position
    fail(hal::FaultKind::aborted, "aborted during motion at " + text(reported(ref_)));
  }
  if (stopped) fail(hal::FaultKind::aborted, "stopped at " + text(reported(ref_)) + " by stop()");
  return out;
}

void SimulatedMachine::home() {
  std::unique_lock lock(mutex_);
  check_can_move(false);
  begin_command();
  const Busy busy(busy_, accepted_, stop_request_);
  const Vec3 home_ref = config_.home_position - active().info.offset;
  // Z first, clear of the part, then across: how every machine homes.
  for (const Vec3& target : {Vec3(ref_.x(), ref_.y(), home_ref.z()), home_ref}) {
    if (run(lock, target, config_.machine.max_speed_mm_s).triggered)
      fail(hal::FaultKind::early_trigger, "the probe triggered while homing at " + text(reported(ref_)));
  }
  homed_ = true;
  fault_.reset();
  fault_message_.clear();
}

void SimulatedMachine::move(const hal::Move& move) {
  std::unique_lock lock(mutex_);
  check_can_move(true);
  check_in_box(move.target, "move target");
  if (move.speed_mm_s < 0 || !std::isfinite(move.speed_mm_s)) throw std::invalid_argument("move speed must be ≥ 0");
  begin_command();
  const Busy busy(busy_, accepted_, stop_request_);
  if (run(lock, move.target - active().info.offset, move.speed_mm_s).triggered)
    fail(hal::FaultKind::early_trigger, "the probe triggered during a guarded move at " + text(reported(ref_)) +
                                            " on the way to " + text(move.target));
  fault_.reset();
}

std::optional<Vec3> SimulatedMachine::true_contact(const hal::ProbeMove& move) const {
  std::lock_guard lock(mutex_);
  const Tip& t = active();
  const Vec3 d = move.direction.normalized();
  const Vec3 start_ref = move.start - t.info.offset;
  auto hit = contact_->first_hit(start_ref + t.true_offset, d, move.max_travel_mm, t.true_radius);
  if (!hit) return std::nullopt;
  return reported(start_ref + d * hit->travel);
}

hal::TouchResult SimulatedMachine::probe(const hal::ProbeMove& move) {
  std::unique_lock lock(mutex_);
  check_can_move(true);
  const double length = move.direction.norm();
  if (!move.direction.allFinite() || !(length > 0.5 && length < 2))
    throw std::invalid_argument("probe direction must be a unit vector");
  if (!(move.max_travel_mm > 0) || !std::isfinite(move.max_travel_mm))
    throw std::invalid_argument("probe max_travel_mm must be > 0");
  if (!(move.min_travel_mm >= 0) || move.min_travel_mm >= move.max_travel_mm)
    throw std::invalid_argument("probe min_travel_mm must be in [0, max_travel_mm)");
  if (!(move.retract_mm >= 0) || !(move.speed_mm_s >= 0)) throw std::invalid_argument("probe retract and speed must be ≥ 0");
  const Vec3 d = move.direction / length;
  check_in_box(move.start, "probe start");
  check_in_box(move.start + d * move.max_travel_mm, "probe end");
  // The farthest a retract can reach back: from a trigger just past the minimum travel.
  check_in_box(move.start - d * std::max(0.0, move.retract_mm - move.min_travel_mm), "probe retract");
  begin_command();
  const Busy busy(busy_, accepted_, stop_request_);

  const Vec3 offset = active().info.offset;
  const Vec3 start_ref = move.start - offset;
  if ((ref_ - start_ref).norm() > 1e-9 &&
      run(lock, start_ref, config_.machine.max_speed_mm_s).triggered)
    fail(hal::FaultKind::early_trigger, "the probe triggered on the way to the search start " + text(move.start));

  const double speed = move.speed_mm_s > 0 ? move.speed_mm_s : config_.machine.probe_speed_mm_s;
  Outcome search = run(lock, start_ref + d * move.max_travel_mm, speed);
  hal::TouchResult result;
  result.tip_id = active().info.id;
  result.travel_mm = search.travel;
  result.t_s = clock_s_;
  if (!search.triggered) {
    result.centre = reported(ref_);
    if (move.fail_on_miss)
      fail(hal::FaultKind::no_contact, "no trigger within " + std::to_string(move.max_travel_mm) + " mm from " +
                                           text(move.start));
    fault_.reset();
    return result;
  }
  // A touch needs real travel: a trigger at the start means the ball was already touching.
  if (search.travel < std::max(move.min_travel_mm, 1e-6))
    fail(hal::FaultKind::early_trigger,
         std::string(search.spurious ? "a spurious trigger" : "a trigger") + " after " +
             std::to_string(search.travel) + " mm, before the search's minimum travel of " +
             std::to_string(move.min_travel_mm) + " mm, from " + text(move.start));
  result.contact = true;
  result.centre = reported(ref_) + d * (config_.trigger_sigma_mm * gaussian());
  if (move.retract_mm > 0 && run(lock, ref_ - d * move.retract_mm, config_.machine.max_speed_mm_s).triggered)
    fail(hal::FaultKind::early_trigger, "the probe triggered while retracting from " + text(result.centre));
  fault_.reset();
  return result;
}

void SimulatedMachine::accept_command() {
  std::lock_guard lock(mutex_);
  if (busy_) return;  // the command will be refused; a stop meant for the running one stands
  accepted_ = true;
  stop_request_ = false;
}

void SimulatedMachine::stop() {
  std::lock_guard lock(mutex_);
  if (busy_ || accepted_) stop_request_ = true;  // an idle machine has nothing to stop
  wake_.notify_all();
}

void SimulatedMachine::abort() {
  std::lock_guard lock(mutex_);
  // Latched at once, whatever the motion thread is doing: an abort that lands just as a motion ends
  // must still refuse the next one.
  if (busy_) abort_request_ = true;
  aborted_ = true;
  fault_ = hal::FaultKind::aborted;
  fault_message_ = busy_ ? "aborted during motion" : "aborted while idle";
  wake_.notify_all();
}

void SimulatedMachine::reset() {
  std::lock_guard lock(mutex_);
  if (busy_) throw hal::StateError("reset() during motion: stop() or abort() first");
  estop_ = aborted_ = false;
  fault_.reset();
  fault_message_.clear();
}

void SimulatedMachine::select_tip(const std::string& tip_id) {
  std::lock_guard lock(mutex_);
  if (busy_) throw hal::StateError("select_tip() during motion");
  active_ = tip_index(tip_id);  // the reference point stays; the reported position follows the tip
}

void SimulatedMachine::record_qualification(const std::string& tip_id, const description::TipQualification& q) {
  std::lock_guard lock(mutex_);
  Tip& t = tips_[tip_index(tip_id)];
  t.info.ball_radius_mm = q.ball_radius_mm;
  t.info.offset = q.offset;
  t.info.qualification = q;
}

}  // namespace cmm::sim
