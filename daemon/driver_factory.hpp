// The one place that knows every driver: the list of names a config's "machine" block may give
// (sim, modbus, grbl) and the hal::Cmm each makes, so the rest of cmmd only ever sees the interface.
// A new driver is its file pair in hal/ and one line here.
#pragma once

#include <memory>
#include <set>
#include <string>

#include "hal/cmm.hpp"

namespace cmm::daemon {

// The driver a config without a "machine" block gets: the in-process simulator.
const char* default_driver_name();
// Every name make_driver() takes, aliases included.
const std::set<std::string>& driver_names();
// The name a driver goes by ("serial" is the Grbl driver's other name): std::invalid_argument for
// one that is not in the list.
std::string canonical_driver_name(const std::string& name);

// Throws std::invalid_argument for an unknown driver name. Relative file names in the driver's
// block (the simulator's part mesh, a machine description) resolve against `base_dir`.
std::unique_ptr<hal::Cmm> make_driver(const std::string& name, const std::string& base_dir);

// The in-process simulator whatever driver the config names: the machine plan.preview dry-runs a
// program on, standing the reference mesh where the plan puts the part.
std::unique_ptr<hal::Cmm> make_simulator(const std::string& base_dir);

}  // namespace cmm::daemon
