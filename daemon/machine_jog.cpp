// The jog's thread and its segments: each a guarded hal Move of at most segment_s of travel, paced to
// the wall clock, inside the travel box; the lease, renewals, replacements and stops around them.
#include "daemon/machine_jog.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <spdlog/spdlog.h>

#include "daemon/client/rpc_error.hpp"
#include "hal/description/eigen_json.hpp"
#include "hal/description/json_fields.hpp"

namespace cmm::daemon {

namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kHolder = "machine.jog";
constexpr double kNoRoomMm = 1e-6;  // a jog with less room than this would leave the box at once

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

std::string mm_text(double mm) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", mm);
  return text;
}

std::string vec_text(const hal::Vec3& v) {
  return std::string("(").append(mm_text(v.x())).append(", ").append(mm_text(v.y())).append(", ").append(mm_text(v.z())).append(")");
}

bool same_direction(const hal::Vec3& a, const hal::Vec3& b) { return a.dot(b) > 1 - 1e-9; }

RpcError fault_error(hal::FaultKind kind, const std::string& message, nlohmann::json data = nlohmann::json::object()) {
  data["kind"] = hal::to_string(kind);
  return RpcError(rpc_code::machine_fault, std::string("machine.jog: ").append(message), std::move(data));
}

}  // namespace

JogRequest jog_request_from_json(const nlohmann::json& params, const JogOptions& options) {
  description::JsonFields f(params);
  JogRequest r;
  if (f.expect_object()) {
    f.known({"direction", "speed_mm_s", "distance_mm", "hold_s"});
    if (f.require("direction", "[x, y, z], not all zero")) {
      const std::size_t problems = f.problem_count();
      const hal::Vec3 d = f.vec3("direction", hal::Vec3::Zero());
      // stableNorm: [1e308, 1e308, 0] is a direction too, and norm() would overflow it to zero.
      if (d.allFinite() && d.stableNorm() > 1e-9) r.direction = d.stableNormalized();
      else if (f.problem_count() == problems) f.problem("direction", "must not be zero");
    }
    r.speed_mm_s = f.number("speed_mm_s", options.max_speed_mm_s, 0.001, options.max_speed_mm_s);
    if (f.has("distance_mm")) r.distance_mm = f.number("distance_mm", 1, 0.0001, 1e5);
    r.hold_s = f.number("hold_s", r.hold_s, 0.01, 1);
    f.finish();
  }
  try {
    f.throw_if_problems("machine.jog");
  } catch (const description::FieldError& e) {
    throw invalid_params(e);
  }
  return r;
}

JogReach jog_reach(const description::TravelBox& box, double margin_mm, const hal::Vec3& from, const hal::Vec3& direction) {
  JogReach reach{std::numeric_limits<double>::infinity(), ""};
  static const char* const kAxes = "xyz";
  for (int i = 0; i < 3; ++i) {
    const double d = direction[i];
    if (std::abs(d) < 1e-12) continue;
    const double face = d > 0 ? box.max[i] - margin_mm : box.min[i] + margin_mm;
    const double mm = std::max(0.0, (face - from[i]) / d);
    if (mm < reach.mm) reach = {mm, std::string(d > 0 ? "+" : "-") + kAxes[i]};
  }
  return reach;
}

MachineJog::MachineJog(MachineLink& machine, JogOptions options, description::TravelBox configured_box)
    : machine_(machine), options_(options), configured_box_(configured_box) {}

MachineJog::~MachineJog() {
  stop();
  if (thread_.joinable()) thread_.join();
}

MachineJog::Command MachineJog::command_for(const JogRequest& request, const std::string& client) {
  return {next_id_++, client, request, Clock::now() + seconds(request.hold_s)};
}

void MachineJog::refuse_if_blocked(const hal::MachineStatus& status, const JogRequest& request) const {
  const std::lock_guard lock(mutex_);
  // The ball is where a jog found a contact, and the probe still reports it: on along that way
  // would only be refused by the machine again (a dashboard button still held keeps asking).
  if (contact_ && status.fault == hal::FaultKind::early_trigger && (status.position - contact_->position).norm() < 1e-6 &&
      request.direction.dot(contact_->direction) > 1e-9)
    throw fault_error(hal::FaultKind::early_trigger,
                      std::string("the probe touched something jogging along ")
                          .append(vec_text(contact_->direction))
                          .append(" and is still there: jog away from it first (against that direction)"));
  const JogReach reach = jog_reach(limits_.box, limits_.margin_mm, status.position, request.direction);
  if (reach.mm < kNoRoomMm) {
    const int axis = static_cast<int>(std::string("xyz").find(reach.face[1]));
    const double limit = reach.face[0] == '+' ? limits_.box.max[axis] - limits_.margin_mm
                                              : limits_.box.min[axis] + limits_.margin_mm;
    throw fault_error(hal::FaultKind::soft_limit,
                      std::string("the ball is at the travel box's ").append(reach.face).append(" face (")
                          .append(1, reach.face[1]).append(reach.face[0] == '+' ? " ≤ " : " ≥ ").append(mm_text(limit))
                          .append(", the box less the ball's radius): jog another way"),
                      {{"face", reach.face}});
  }
}

hal::MachineStatus MachineJog::read_status() {
  try {
    return machine_.cmm().status();
  } catch (const hal::Fault& fault) {
    throw fault_error(fault.kind(), fault.what());
  } catch (const hal::StateError& e) {
    throw RpcError(rpc_code::invalid_state, std::string("machine.jog: ").append(e.what()));
  }
}

MachineJog::Started MachineJog::jog(const JogRequest& request, const std::string& client) {
  const std::lock_guard start(start_mutex_);
  {
    std::unique_lock lock(mutex_);
    if (running_ && !stop_) {
      Command& c = command_;
      if (c.client != client) {
        const int id = c.id;
        const std::string owner = c.client;
        lock.unlock();
        throw RpcError(rpc_code::machine_busy,
                       "machine.jog: jog " + std::to_string(id) + " of another client (" + owner +
                           ") is running: only it renews or replaces it; machine.jog_stop stops it",
                       {{"holder", "machine.jog"}, {"jog", id}});
      }
      if (!request.distance_mm && !c.request.distance_mm && same_direction(request.direction, c.request.direction)) {
        c.deadline = Clock::now() + seconds(request.hold_s);
        c.request.speed_mm_s = request.speed_mm_s;
        c.request.hold_s = request.hold_s;
        const int id = c.id;
        lock.unlock();
        return {id, read_status().position, true};
      }
      lock.unlock();
      const hal::MachineStatus status = read_status();
      refuse_if_blocked(status, request);
      lock.lock();
      if (running_ && !stop_) {  // else it ended meanwhile (a fault, a stop): start afresh below
        command_ = command_for(request, client);
        const int id = command_.id;
        lock.unlock();
        wake_.notify_all();
        spdlog::info("jog {}: {} at {} mm/s, replacing the one running", id, vec_text(request.direction), request.speed_mm_s);
        return {id, status.position, false};
      }
    }
  }
  if (thread_.joinable()) thread_.join();  // it has ended, and is only letting the machine go

  std::function<void()> check_stop = machine_.stop_check();
  std::optional<MachineLink::Lease> lease = machine_.lease_after_reconnect(kHolder, std::chrono::seconds(10));
  if (!lease) {
    const std::string holder = machine_.holder().value_or("another command");
    throw RpcError(rpc_code::machine_busy, "machine.jog: the machine is busy: " + holder + " holds it", {{"holder", holder}});
  }
  hal::MachineStatus status;
  try {
    machine_.bring_up();
    if (const auto line = machine_.touch_in_progress())
      throw RpcError(rpc_code::invalid_state,
                     std::string("machine.jog: the ball may still be on the search line of a touch a stop cut short (from ")
                         .append(vec_text(line->start))
                         .append("): machine.home leaves along it; then jog"));
    status = machine_.cmm().status();
    if (!status.homed)
      throw fault_error(hal::FaultKind::not_homed, "the machine is not homed: machine.home first");
    const description::MachineDescription info = machine_.cmm().info();
    Limits limits;
    limits.box.min = configured_box_.min.cwiseMax(info.travel_box.min);
    limits.box.max = configured_box_.max.cwiseMin(info.travel_box.max);
    limits.margin_mm = info.tip().ball_radius_mm;
    {
      const std::lock_guard lock(mutex_);
      limits_ = limits;
    }
    refuse_if_blocked(status, request);
  } catch (const hal::Fault& fault) {
    throw fault_error(fault.kind(), fault.what());
  } catch (const hal::StateError& e) {
    throw RpcError(rpc_code::invalid_state, std::string("machine.jog: ").append(e.what()));
  } catch (const std::invalid_argument& e) {  // the machine's active tip is none of its tips
    throw RpcError(rpc_code::invalid_state, std::string("machine.jog: ").append(e.what()));
  }
  int id = 0;
  {
    const std::lock_guard lock(mutex_);
    command_ = command_for(request, client);
    id = command_.id;
    running_ = true;
    stop_ = false;
    thread_ = std::thread(&MachineJog::run, this, std::move(lease), std::move(check_stop));
  }
  spdlog::info("jog {}: {} at {} mm/s{}", id, vec_text(request.direction), request.speed_mm_s,
               request.distance_mm ? std::string(" for ").append(mm_text(*request.distance_mm)).append(" mm") : std::string(", held"));
  return {id, status.position, false};
}

// Between segments the lock is held; a segment, a status read and the stop check run without it,
// so that renewals, replacements and stops never wait for the machine.
void MachineJog::run(std::optional<MachineLink::Lease> lease, std::function<void()> check_stop) {
  hal::Cmm& cmm = machine_.cmm();
  JogEnd end;
  std::unique_lock lock(mutex_);
  int picked = 0;  // the command this loop is running
  hal::Vec3 start = hal::Vec3::Zero(), direction = hal::Vec3::UnitX();
  double done_mm = 0, end_mm = 0;
  std::string end_reason;
  try {
    for (;;) {
      if (stop_) {  // between segments: Aborted all the same, as a stop during one ends
        end.fault = hal::FaultKind::aborted;
        end.reason = "stopped by machine.jog_stop";
        break;
      }
      if (command_.id != picked) {  // a new jog, or one replacing the last
        picked = command_.id;
        direction = command_.request.direction;
        const std::optional<double> distance = command_.request.distance_mm;
        lock.unlock();
        start = cmm.status().position;
        lock.lock();
        if (command_.id != picked || stop_) continue;
        const JogReach reach = jog_reach(limits_.box, limits_.margin_mm, start, direction);
        done_mm = 0;
        end_mm = std::min(reach.mm, distance.value_or(reach.mm));
        end_reason = distance && *distance <= reach.mm ? std::string("travelled ").append(mm_text(*distance)).append(" mm")
                                                       : "at the travel box's " + reach.face + " face";
      }
      if (!command_.request.distance_mm && Clock::now() >= command_.deadline) {
        end.reason = "released (no machine.jog within hold_s)";
        break;
      }
      if (done_mm >= end_mm - kNoRoomMm) {
        end.reason = end_reason;
        break;
      }
      const double speed = command_.request.speed_mm_s;
      const double next_mm = std::min(done_mm + speed * options_.segment_s, end_mm);
      // Clamped into the box itself against rounding: never a target outside it.
      const hal::Vec3 target = (start + direction * next_mm).cwiseMax(limits_.box.min).cwiseMin(limits_.box.max);
      const Clock::time_point began = Clock::now();
      lock.unlock();
      check_stop();  // a machine.stop (or shutdown) since the jog began ends it, also between segments
      cmm.move({target, speed});
      lock.lock();
      contact_.reset();
      // A machine that answers before the segment's time (a simulator on a virtual clock) waits
      // here, so that a jog never outruns its speed on the wall clock the operator's hand is on.
      wake_.wait_until(lock, began + seconds((next_mm - done_mm) / speed), [&] { return stop_ || command_.id != picked; });
      done_mm = next_mm;
    }
  } catch (const hal::Fault& fault) {
    if (!lock.owns_lock()) lock.lock();
    end.fault = fault.kind();
    end.reason = stop_ ? "stopped by machine.jog_stop" : fault.what();
  } catch (const std::exception& e) {  // a StateError (the link went down under it), or worse
    if (!lock.owns_lock()) lock.lock();
    end.reason = e.what();
  }
  if (end.fault == hal::FaultKind::early_trigger) {
    lock.unlock();
    std::optional<hal::Vec3> at;
    try {
      at = cmm.status().position;
    } catch (const std::exception&) {
      // Where it stopped is unknown: no refusal of ours; the machine's guarded move meets the contact again.
    }
    lock.lock();
    if (at) contact_ = Contact{direction, *at};
  }
  // The machine is free before the jog reads as ended, so a command sent on seeing it ended finds it free.
  lock.unlock();
  lease.reset();
  lock.lock();
  // A jog that replaced this one just as it ended ends with it: its caller reads why in last_jog.
  end.id = command_.id;
  last_ = end;
  running_ = false;
  lock.unlock();
  if (end.fault) spdlog::warn("jog {} ended: {}", end.id, end.reason);
  else spdlog::info("jog {} ended: {}", end.id, end.reason);
}

void MachineJog::stop() {
  {
    const std::lock_guard lock(mutex_);
    if (!running_) return;
    stop_ = true;
  }
  wake_.notify_all();
  try {
    machine_.cmm().stop();  // the segment in progress; the thread then sees stop_ and ends
  } catch (const std::exception& e) {
    spdlog::debug("jog stop: {}", e.what());  // not connected: nothing moves
  }
}

nlohmann::json MachineJog::status_json() const {
  const std::lock_guard lock(mutex_);
  if (!running_ || stop_) return nullptr;
  const JogRequest& r = command_.request;
  return {{"id", command_.id},
          {"direction", description::vec3_json(r.direction)},
          {"speed_mm_s", r.speed_mm_s},
          {"distance_mm", r.distance_mm ? nlohmann::json(*r.distance_mm) : nlohmann::json(nullptr)}};
}

nlohmann::json MachineJog::last_json() const {
  const std::lock_guard lock(mutex_);
  if (!last_) return nullptr;
  return {{"id", last_->id},
          {"reason", last_->reason},
          {"fault", last_->fault ? nlohmann::json(hal::to_string(*last_->fault)) : nlohmann::json(nullptr)}};
}

std::optional<JogEnd> MachineJog::last_end() const {
  const std::lock_guard lock(mutex_);
  return last_;
}

bool MachineJog::running() const {
  const std::lock_guard lock(mutex_);
  return running_;
}

void add_jog_methods(RpcDispatcher& d, const std::shared_ptr<MachineJog>& jog) {
  d.add("machine.jog", {Role::operator_, Work::blocking, [jog](const nlohmann::json& params, RpcContext& ctx) {
          const JogRequest request = jog_request_from_json(params, jog->options());
          const MachineJog::Started s = jog->jog(request, ctx.client());
          return nlohmann::json{{"jog", s.id},
                                {"position", description::vec3_json(s.position)},
                                {"direction", description::vec3_json(request.direction)},
                                {"speed_mm_s", request.speed_mm_s},
                                {"renewed", s.renewed}};
        }});
  d.add("machine.jog_stop", {Role::observer, Work::quick, [jog](const nlohmann::json&, RpcContext& ctx) {
          spdlog::info("machine.jog_stop from {}", ctx.peer());
          jog->stop();
          return nlohmann::json::object();
        }});
}

}  // namespace cmm::daemon
