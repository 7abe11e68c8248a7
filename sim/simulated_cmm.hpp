// The in-process simulator as a hal::Cmm driver: the link faults of the config (emulated at the
// API, as a transport would show them) in front of one SimulatedMachine; the lifecycle is the
// driver base's.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>

#include "hal/cmm_driver.hpp"
#include "sim/simulated_machine.hpp"

namespace cmm::sim {

class SimulatedCmm : public hal::CmmDriver {
 public:
  // Relative file names in the config block resolve against base_dir.
  explicit SimulatedCmm(std::string base_dir = ".");
  ~SimulatedCmm() override;

  std::optional<description::MachineDescription> configured_machine() const override;

  // The machine behind the link, for tests that compare with the truth. Null before connect().
  SimulatedMachine* machine() { return machine_.get(); }

 protected:
  std::string where() const override { return "the simulator"; }
  void on_configure(const nlohmann::json& block) override;
  void on_connect() override;  // builds the machine (reads the part's mesh file) the first time
  void on_enable() override;
  void on_disconnect() override {}
  description::MachineDescription read_info() override;
  hal::MachineStatus read_status() override;
  void do_home() override;
  void do_move(const hal::Move& move) override;
  hal::TouchResult do_probe(const hal::ProbeMove& move) override;
  // stop and abort reach the machine whatever the lifecycle and the link say: they only ever make it
  // safer, and it is in-process.
  void do_stop() override;
  void do_abort() override;
  void do_reset() override;
  void do_select_tip(const std::string& tip_id) override;
  void do_record_qualification(const std::string& tip_id, const description::TipQualification& q) override;

 private:
  // One command over the emulated link (home, move, probe, reset, select_tip, record_qualification;
  // status and info polls are not counted, as a transport's would not be): counts it and applies the
  // configured drop, delay and corruption.
  template <class F>
  auto command(const char* name, bool motion, F&& f);

  std::string base_dir_;
  std::optional<SimConfig> config_;
  std::unique_ptr<SimulatedMachine> machine_;
  std::atomic<int> commands_{0};
  std::atomic<bool> link_down_{false};
  bool dropped_ = false;
};

}  // namespace cmm::sim
