// The one place that knows every driver: makes the hal::Cmm a config's "machine" block names
// (sim, modbus, grbl), so the rest of cmmd only ever sees the interface.
#pragma once

#include <memory>
#include <string>

#include "hal/cmm.hpp"

namespace cmm::daemon {

// Throws std::invalid_argument for an unknown driver name. Relative file names in the driver's
// block (the simulator's part mesh) resolve against `base_dir`.
std::unique_ptr<hal::Cmm> make_driver(const std::string& driver, const std::string& base_dir);

}  // namespace cmm::daemon
