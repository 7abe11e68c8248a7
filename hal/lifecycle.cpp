// Lifecycle names for status reports and errors.
#include "hal/machine_info.hpp"

#include <string>

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

void require_lifecycle(Lifecycle now, Lifecycle needed, const char* what, const char* machine) {
  if (now < needed)
    throw StateError(std::string(what) + ": " + machine + " is " + to_string(now) + ", needs " + to_string(needed));
}

}  // namespace cmm::hal
