// What a machine is doing from moment to moment (MachineStatus) and where its driver stands in the
// lifecycle; what it is (travel box, tips, …) is its description (hal/description/).
#pragma once

#include <optional>
#include <string>

#include "hal/fault.hpp"
#include "hal/motion.hpp"

namespace cmm::hal {

// configure → connect → enable; disable and faults drop back to connected; disconnect to configured.
enum class Lifecycle { unconfigured, configured, connected, enabled };
const char* to_string(Lifecycle state);

// What the machine is doing now. `fault` holds the last fault until the next motion succeeds or
// reset() clears a latched one (abort, e-stop).
struct MachineStatus {
  Lifecycle lifecycle = Lifecycle::unconfigured;
  bool homed = false;
  bool moving = false;
  bool estop = false;    // the machine's e-stop input is active
  bool aborted = false;  // abort() latched; reset() clears it
  Vec3 position = Vec3::Zero();  // ball centre of the active tip, M (meaningful once homed)
  std::optional<FaultKind> fault;
  std::string fault_message;
  std::string tip_id;
  double t_s = 0;  // machine clock
};

}  // namespace cmm::hal
