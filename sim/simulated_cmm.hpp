// The in-process simulator as a hal::Cmm driver: the lifecycle and the link faults of the config
// (emulated at the API, as a transport would show them) around one SimulatedMachine.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "hal/cmm.hpp"
#include "sim/simulated_machine.hpp"

namespace cmm::sim {

class SimulatedCmm : public hal::Cmm {
 public:
  // Relative file names in the config block resolve against base_dir.
  explicit SimulatedCmm(std::string base_dir = ".");

  void configure(const nlohmann::json& block) override;
  void connect() override;  // builds the machine (reads the part's mesh file) the first time
  void enable() override;
  void disable() override;
  void disconnect() override;

  hal::MachineInfo info() override;
  hal::MachineStatus status() override;
  void home() override;
  void move(const hal::Move& move) override;
  hal::TouchResult probe(const hal::ProbeMove& move) override;
  void stop() override;
  void abort() override;
  void reset() override;
  void select_tip(const std::string& tip_id) override;
  void record_qualification(const std::string& tip_id, const hal::TipQualification& q) override;

  // The machine behind the link, for tests that compare with the truth. Null before connect().
  SimulatedMachine* machine() { return machine_.get(); }

 private:
  // One command over the emulated link (home, move, probe, reset, select_tip, record_qualification;
  // status and info polls are not counted, as a transport's would not be): counts it, applies drop/delay/corrupt, and drops an enabled
  // machine back to connected when the machine faults.
  template <class F>
  auto command(const char* name, bool motion, F&& f);
  void require(hal::Lifecycle at_least, const char* what) const;

  std::string base_dir_;
  std::optional<SimConfig> config_;
  std::unique_ptr<SimulatedMachine> machine_;
  std::atomic<hal::Lifecycle> lifecycle_{hal::Lifecycle::unconfigured};
  std::atomic<int> commands_{0};
  std::atomic<bool> link_down_{false};
  bool dropped_ = false;
};

}  // namespace cmm::sim
