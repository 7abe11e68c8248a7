// In-process driver: lifecycle checks and emulated link faults, then the simulated machine.
#include "sim/simulated_cmm.hpp"

#include <cmath>

namespace cmm::sim {

SimulatedCmm::SimulatedCmm(std::string base_dir) : base_dir_(std::move(base_dir)) {}

void SimulatedCmm::require(hal::Lifecycle at_least, const char* what) const {
  hal::require_lifecycle(lifecycle_.load(), at_least, what, "the simulator");
}

template <class F>
auto SimulatedCmm::command(const char* name, bool motion, F&& f) {
  require(motion ? hal::Lifecycle::enabled : hal::Lifecycle::connected, name);
  const auto& faults = config_->faults;
  if (link_down_) throw hal::CommLost(std::string(name) + ": the link to the simulator is down");
  const int n = ++commands_;
  if (faults.drop_link_after_commands > 0 && n > faults.drop_link_after_commands && !dropped_) {
    link_down_ = dropped_ = true;  // once: the link may come back, as a cable put back in does
    lifecycle_ = hal::Lifecycle::configured;
    throw hal::CommLost(std::string(name) + ": the link dropped after " +
                        std::to_string(faults.drop_link_after_commands) + " commands");
  }
  // A reply later than the timeout is, to the caller, a timeout; the machine may still have acted,
  // which is exactly what a real link leaves a driver not knowing.
  if (faults.reply_delay_s > config_->timeout_s)
    throw hal::Timeout(std::string(name) + ": no reply within " + std::to_string(config_->timeout_s) + " s");
  if (n == faults.corrupt_reply_at_command)
    throw hal::Protocol(std::string(name) + ": the reply to command " + std::to_string(n) + " was corrupt");
  try {
    if (motion) machine_->accept_command();
    return f();
  } catch (const hal::Fault&) {
    if (motion && lifecycle_ == hal::Lifecycle::enabled) lifecycle_ = hal::Lifecycle::connected;
    throw;
  }
}

void SimulatedCmm::configure(const nlohmann::json& block) {
  if (lifecycle_ >= hal::Lifecycle::connected) throw hal::StateError("configure: disconnect first");
  config_ = sim_config_from_json(block, base_dir_);
  machine_.reset();
  lifecycle_ = hal::Lifecycle::configured;
}

void SimulatedCmm::connect() {
  require(hal::Lifecycle::configured, "connect");
  if (lifecycle_ >= hal::Lifecycle::connected) return;
  if (!machine_) machine_ = std::make_unique<SimulatedMachine>(*config_);
  link_down_ = false;
  commands_ = 0;
  lifecycle_ = hal::Lifecycle::connected;
}

void SimulatedCmm::enable() {
  require(hal::Lifecycle::connected, "enable");
  if (link_down_) throw hal::CommLost("enable: the link to the simulator is down");
  lifecycle_ = hal::Lifecycle::enabled;
}

void SimulatedCmm::disable() {
  if (lifecycle_ == hal::Lifecycle::enabled) lifecycle_ = hal::Lifecycle::connected;
}

void SimulatedCmm::disconnect() {
  if (lifecycle_ >= hal::Lifecycle::connected) lifecycle_ = hal::Lifecycle::configured;
}

hal::MachineInfo SimulatedCmm::info() {
  require(hal::Lifecycle::connected, "info");
  if (link_down_) throw hal::CommLost("info: the link to the simulator is down");
  return machine_->info();
}

hal::MachineStatus SimulatedCmm::status() {
  require(hal::Lifecycle::connected, "status");
  if (link_down_) throw hal::CommLost("status: the link to the simulator is down");
  hal::MachineStatus s = machine_->status();
  s.lifecycle = lifecycle_;
  return s;
}

void SimulatedCmm::home() {
  command("home", true, [&] { machine_->home(); });
}
void SimulatedCmm::move(const hal::Move& move) {
  command("move", true, [&] { machine_->move(move); });
}
hal::TouchResult SimulatedCmm::probe(const hal::ProbeMove& move) {
  return command("probe", true, [&] { return machine_->probe(move); });
}

// stop and abort must work whatever the lifecycle and the link say: they only ever make the
// machine safer, and the machine is in-process, so they always reach it.
void SimulatedCmm::stop() {
  if (machine_) machine_->stop();
}
void SimulatedCmm::abort() {
  if (machine_) machine_->abort();
  if (lifecycle_ == hal::Lifecycle::enabled) lifecycle_ = hal::Lifecycle::connected;
}

void SimulatedCmm::reset() {
  command("reset", false, [&] { machine_->reset(); });
}
void SimulatedCmm::select_tip(const std::string& tip_id) {
  command("select_tip", false, [&] { machine_->select_tip(tip_id); });
}
void SimulatedCmm::record_qualification(const std::string& tip_id, const hal::TipQualification& q) {
  command("record_qualification", false, [&] { machine_->record_qualification(tip_id, q); });
}

}  // namespace cmm::sim
