// In-process driver: emulated link faults, then the simulated machine.
#include "sim/simulated_cmm.hpp"

#include <cmath>

namespace cmm::sim {

SimulatedCmm::SimulatedCmm(std::string base_dir) : CmmDriver("the simulator"), base_dir_(std::move(base_dir)) {}
SimulatedCmm::~SimulatedCmm() { disconnect(); }

std::optional<description::MachineDescription> SimulatedCmm::configured_machine() const {
  if (!config_) return std::nullopt;
  return config_->machine;
}

template <class F>
auto SimulatedCmm::command(const char* name, bool motion, F&& f) {
  const auto& faults = config_->faults;
  if (link_down_) throw hal::CommLost(std::string(name) + ": the link to the simulator is down");
  const int n = ++commands_;
  if (faults.drop_link_after_commands > 0 && n > faults.drop_link_after_commands && !dropped_) {
    link_down_ = dropped_ = true;  // once: the link may come back, as a cable put back in does
    drop_link();
    throw hal::CommLost(std::string(name) + ": the link dropped after " +
                        std::to_string(faults.drop_link_after_commands) + " commands");
  }
  // A reply later than the timeout is, to the caller, a timeout; the machine may still have acted,
  // which is exactly what a real link leaves a driver not knowing.
  if (faults.reply_delay_s > config_->timeout_s)
    throw hal::Timeout(std::string(name) + ": no reply within " + std::to_string(config_->timeout_s) + " s");
  if (n == faults.corrupt_reply_at_command)
    throw hal::Protocol(std::string(name) + ": the reply to command " + std::to_string(n) + " was corrupt");
  if (motion) machine_->accept_command();
  return f();
}

void SimulatedCmm::on_configure(const nlohmann::json& block) {
  config_ = sim_config_from_json(block, base_dir_);
  machine_.reset();
}

void SimulatedCmm::on_connect() {
  if (!machine_) machine_ = std::make_unique<SimulatedMachine>(*config_);
  link_down_ = false;
  commands_ = 0;
}

void SimulatedCmm::on_enable() {
  if (link_down_) throw hal::CommLost("enable: the link to the simulator is down");
}

description::MachineDescription SimulatedCmm::read_info() {
  if (link_down_) throw hal::CommLost("info: the link to the simulator is down");
  return machine_->info();
}

hal::MachineStatus SimulatedCmm::read_status() {
  if (link_down_) throw hal::CommLost("status: the link to the simulator is down");
  return machine_->status();
}

void SimulatedCmm::do_home() {
  command("home", true, [&] { machine_->home(); });
}
void SimulatedCmm::do_move(const hal::Move& move) {
  command("move", true, [&] { machine_->move(move); });
}
hal::TouchResult SimulatedCmm::do_probe(const hal::ProbeMove& move) {
  return command("probe", true, [&] { return machine_->probe(move); });
}

void SimulatedCmm::do_stop() {
  if (machine_) machine_->stop();
}
void SimulatedCmm::do_abort() {
  if (machine_) machine_->abort();
}

void SimulatedCmm::do_reset() {
  command("reset", false, [&] { machine_->reset(); });
}
void SimulatedCmm::do_select_tip(const std::string& tip_id) {
  command("select_tip", false, [&] { machine_->select_tip(tip_id); });
}
void SimulatedCmm::do_record_qualification(const std::string& tip_id, const description::TipQualification& q) {
  command("record_qualification", false, [&] { machine_->record_qualification(tip_id, q); });
}

}  // namespace cmm::sim
