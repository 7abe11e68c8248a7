#include "daemon/machine_link.hpp"

#include "hal/fault.hpp"

namespace cmm::daemon {

namespace {

nlohmann::json vec(const hal::Vec3& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

MachineLink::MachineLink(std::unique_ptr<hal::Cmm> cmm, nlohmann::json block, std::string driver)
    : cmm_(std::move(cmm)), block_(std::move(block)), driver_(std::move(driver)) {}

void MachineLink::bring_up() {
  const std::lock_guard lock(bring_up_mutex_);
  if (!configured_) {
    cmm_->configure(block_);
    configured_ = true;
  }
  // Both are no-ops for a driver already that far (and status() cannot be asked before connect).
  cmm_->connect();
  cmm_->enable();
}

nlohmann::json MachineLink::status_json() {
  nlohmann::json j = {{"driver", driver_}};
  try {
    const hal::MachineStatus s = cmm_->status();
    const bool up = s.lifecycle == hal::Lifecycle::connected || s.lifecycle == hal::Lifecycle::enabled;
    j.update({{"lifecycle", hal::to_string(s.lifecycle)},
              {"link", up ? "up" : "down"},
              {"homed", s.homed},
              {"moving", s.moving},
              {"estop", s.estop},
              {"aborted", s.aborted},
              {"position", vec(s.position)},
              {"tip", s.tip_id},
              {"t_s", s.t_s},
              {"fault", s.fault ? nlohmann::json{{"kind", hal::to_string(*s.fault)}, {"message", s.fault_message}}
                                : nlohmann::json(nullptr)}});
  } catch (const std::exception& e) {
    j.update({{"lifecycle", "unknown"}, {"link", "down"}, {"fault", fault_json(e)}});
  }
  j["job"] = nullptr;
  if (const auto h = holder()) j["holder"] = *h;
  return j;
}

MachineLink::Lease::~Lease() {
  if (link_ == nullptr) return;
  const std::lock_guard lock(link_->lease_mutex_);
  link_->holder_.reset();
}

std::optional<MachineLink::Lease> MachineLink::try_lease(const std::string& holder) {
  const std::lock_guard lock(lease_mutex_);
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
