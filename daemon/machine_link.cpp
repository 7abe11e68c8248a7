// cmmd's one machine: bringing the driver up, leasing it, the touch in progress, and qualification.
#include "daemon/machine_link.hpp"

#include <fstream>

#include <spdlog/spdlog.h>

#include "hal/description/eigen_json.hpp"
#include "geometry/atomic_file.hpp"
#include "hal/fault.hpp"
#include "hal/utc_time.hpp"

namespace cmm::daemon {

MachineLink::MachineLink(std::unique_ptr<hal::Cmm> cmm, nlohmann::json block, std::string driver,
                         std::filesystem::path touch_file)
    : cmm_(std::move(cmm)), block_(std::move(block)), driver_(std::move(driver)), touch_file_(std::move(touch_file)) {
  if (touch_file_.empty() || !std::filesystem::exists(touch_file_)) return;
  try {
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(touch_file_));
    SearchLine line;
    line.start = description::vec3_from_json(j.at("start"));
    line.direction = description::vec3_from_json(j.at("direction"));
    touch_ = line;
    spdlog::warn("the probe may still be on the search line from ({}, {}, {}): the next motion leaves along it",
                 line.start.x(), line.start.y(), line.start.z());
  } catch (const std::exception& e) {
    spdlog::error("{}: unreadable ({}); ignored", touch_file_.string(), e.what());
  }
}

void MachineLink::enter_touch(const SearchLine& line) {
  const std::lock_guard lock(touch_mutex_);
  if (!touch_file_.empty())
    geometry::write_atomically(touch_file_, nlohmann::json{{"start", description::vec3_json(line.start)}, {"direction", description::vec3_json(line.direction)}}.dump());
  touch_ = line;
}

void MachineLink::left_touch() {
  const std::lock_guard lock(touch_mutex_);
  if (!touch_) return;
  touch_.reset();
  if (!touch_file_.empty()) {
    std::error_code ignored;
    std::filesystem::remove(touch_file_, ignored);
  }
}

std::optional<SearchLine> MachineLink::touch_in_progress() const {
  const std::lock_guard lock(touch_mutex_);
  return touch_;
}

std::function<void()> MachineLink::stop_check() const {
  return [this, since = stops_.load()] {
    if (stops_.load() != since) throw hal::Fault(hal::FaultKind::aborted, "stopped by machine.stop");
  };
}

void MachineLink::bring_up() {
  const std::lock_guard lock(bring_up_mutex_);
  bool was_up = true;
  try {
    if (!configured_) {
      cmm_->configure(block_);
      configured_ = true;
    }
    try {
      (void)cmm_->status();
    } catch (const std::exception&) {
      was_up = false;  // not connected (StateError), or the link just broke (CommLost)
    }
    // A no-op for a driver already connected (and status() cannot be asked before connect).
    cmm_->connect();
  } catch (const std::exception& e) {
    nlohmann::json why = fault_json(e);
    why["utc"] = hal::utc_now();
    const std::lock_guard error_lock(connect_error_mutex_);
    connect_error_ = std::move(why);
    throw;
  }
  {
    const std::lock_guard error_lock(connect_error_mutex_);
    connect_error_ = nullptr;
  }
  if (!was_up) ++connections_;
  cmm_->enable();  // a refusal here is no connect error: the link is up and status() reads the machine
}

nlohmann::json MachineLink::connect_error() const {
  const std::lock_guard lock(connect_error_mutex_);
  return connect_error_;
}

description::TipQualification MachineLink::qualify(const std::string& tip_id, const hal::QualificationOptions& options) {
  const description::TipQualification q = hal::qualify(*cmm_, tip_id, options);
  for (const description::StylusTip& tip : cmm_->info().tips)
    if (tip.id == tip_id) {
      const std::lock_guard lock(qualified_mutex_);
      qualified_[tip_id] = tip;
    }
  return q;
}

std::optional<description::StylusTip> MachineLink::qualified_by_cmmd(const std::string& tip_id) const {
  const std::lock_guard lock(qualified_mutex_);
  const auto it = qualified_.find(tip_id);
  if (it == qualified_.end()) return std::nullopt;
  return it->second;
}

nlohmann::json MachineLink::status_json() {
  const nlohmann::json why_down = connect_error();
  nlohmann::json j = {{"driver", driver_}, {"connect_error", why_down}};
  try {
    const hal::MachineStatus s = cmm_->status();
    const bool up = s.lifecycle == hal::Lifecycle::connected || s.lifecycle == hal::Lifecycle::enabled;
    j.update({{"lifecycle", hal::to_string(s.lifecycle)},
              {"link", up ? "up" : "down"},
              {"homed", s.homed},
              {"moving", s.moving},
              {"estop", up ? nlohmann::json(s.estop) : nlohmann::json(nullptr)},
              {"aborted", s.aborted},
              {"position", description::vec3_json(s.position)},
              {"tip", s.tip_id},
              {"t_s", s.t_s},
              {"fault", s.fault ? nlohmann::json{{"kind", hal::to_string(*s.fault)}, {"message", s.fault_message}}
                                : nlohmann::json(nullptr)}});
  } catch (const hal::StateError&) {
    // Not connected. Nothing the machine reports is known, its e-stop least of all (a released one
    // must not be shown while it may be pressed); the fault is why the last connect failed, not
    // this refusal to read a status.
    j.update({{"lifecycle", configured_ ? "configured" : "unconfigured"},
              {"link", "down"},
              {"estop", nullptr},
              {"fault", why_down.is_null() ? nlohmann::json(nullptr)
                                           : nlohmann::json{{"kind", why_down.at("kind")}, {"message", why_down.at("message")}}}});
  } catch (const std::exception& e) {
    j.update({{"lifecycle", "unknown"}, {"link", "down"}, {"estop", nullptr}, {"fault", fault_json(e)}});
  }
  j["job"] = nullptr;
  if (const auto h = holder()) j["holder"] = *h;
  return j;
}

nlohmann::json MachineLink::tips_json() {
  nlohmann::json tips = nlohmann::json::array();
  try {
    const description::MachineDescription info = cmm_->info();
    for (const description::StylusTip& t : info.tips) {
      nlohmann::json q = nullptr;
      if (t.qualification)
        q = {{"time_utc", t.qualification->time_utc},
             {"ball_radius_mm", t.qualification->ball_radius_mm},
             {"residual_rms_mm", t.qualification->residual_rms_mm}};
      tips.push_back({{"id", t.id},
                      {"active", t.id == info.active_tip},
                      {"ball_radius_mm", t.ball_radius_mm},
                      {"offset", description::vec3_json(t.offset)},
                      {"qualified", t.qualification.has_value()},
                      {"qualification", q}});
    }
  } catch (const std::exception&) {
    // Not connected: the machine cannot say; status_json's fault says why.
  }
  return tips;
}

MachineLink::Lease::~Lease() {
  if (link_ == nullptr) return;
  {
    const std::lock_guard lock(link_->lease_mutex_);
    link_->holder_.reset();
  }
  link_->released_.notify_all();
}

std::optional<MachineLink::Lease> MachineLink::try_lease(const std::string& holder) {
  const std::lock_guard lock(lease_mutex_);
  if (holder_) return std::nullopt;
  holder_ = holder;
  return std::optional<Lease>(std::in_place, *this);
}

std::optional<MachineLink::Lease> MachineLink::lease_after_reconnect(const std::string& holder,
                                                                    std::chrono::milliseconds patience) {
  std::unique_lock lock(lease_mutex_);
  released_.wait_for(lock, patience, [this] { return !holder_ || *holder_ != kReconnectHolder; });
  if (holder_) return std::nullopt;
  holder_ = holder;
  return std::optional<Lease>(std::in_place, *this);
}

std::optional<std::string> MachineLink::holder() const {
  const std::lock_guard lock(lease_mutex_);
  return holder_;
}

nlohmann::json fault_json(const std::exception& e) {
  if (const auto* fault = dynamic_cast<const hal::Fault*>(&e))
    return {{"kind", hal::to_string(fault->kind())}, {"message", fault->what()}};
  return {{"kind", "Internal"}, {"message", e.what()}};
}

}  // namespace cmm::daemon
