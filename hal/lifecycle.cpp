// Lifecycle names, for status reports and the driver base's errors.
#include "hal/machine_status.hpp"

namespace cmm::hal {

const char* to_string(Lifecycle state) {
  switch (state) {
    case Lifecycle::unconfigured: return "unconfigured";
    case Lifecycle::configured: return "configured";
    case Lifecycle::connected: return "connected";
    case Lifecycle::enabled: return "enabled";
  }
  return "unknown";
}

}  // namespace cmm::hal
