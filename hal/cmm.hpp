// hal::Cmm, the one interface every machine is driven through (DESIGN.md): the simulator, a Modbus
// machine and a Grbl serial machine each implement it, through the driver base (hal/cmm_driver.hpp);
// a driver never knows about jobs.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "hal/description/machine_description.hpp"
#include "hal/machine_status.hpp"
#include "hal/motion.hpp"

namespace cmm::hal {

// Lifecycle (ros2_control's habit): configure(block) parses the driver's block, no I/O (a bad block
// throws description::FieldError naming every bad key by its pointer); connect() brings the link up
// so status() is readable; enable() allows motion. A fault drops an enabled machine back to
// connected (the caller looks at it, enables again); a fault of the link (CommLost, an unanswered
// request) to configured.
//
// Threads: home, move and probe block until done or faulted, one at a time. status(), stop() and
// abort() may be called from any other thread while they run. A driver never reports a touch it did
// not see, and after a reconnect it re-reads the machine state and never replays a motion whose
// outcome it does not know.
class Cmm {
 public:
  virtual ~Cmm() = default;

  virtual void configure(const nlohmann::json& block) = 0;
  virtual void connect() = 0;
  virtual void enable() = 0;
  virtual void disable() = 0;
  virtual void disconnect() = 0;

  // The machine as its configuration describes it, before any connection: a simulator's or a Grbl
  // machine's machine.json; nullopt for a machine that describes itself only once connected (Modbus).
  virtual std::optional<description::MachineDescription> configured_machine() const = 0;
  // The machine as it reports itself (connected): travel box, limits, tips with their qualification.
  virtual description::MachineDescription info() = 0;
  virtual MachineStatus status() = 0;

  virtual void home() = 0;
  virtual void move(const Move& move) = 0;
  virtual TouchResult probe(const ProbeMove& move) = 0;
  virtual void stop() = 0;   // controlled stop, position kept; the running call throws Aborted
  virtual void abort() = 0;  // immediate software stop, latched: motion is refused until reset()
  virtual void reset() = 0;  // clears a latched abort or e-stop (if the input is released)

  // Makes `tip_id` the active tip; positions and touches are then its ball centre.
  virtual void select_tip(const std::string& tip_id) = 0;
  // Stores a qualification (hal/qualification.hpp measures it): from now on the tip's offset and
  // radius are the qualified ones, and info() reports them with their time stamp.
  virtual void record_qualification(const std::string& tip_id, const description::TipQualification& q) = 0;
};

}  // namespace cmm::hal
