#include "daemon/driver_factory.hpp"

#include <stdexcept>

#include "hal/grbl_cmm.hpp"
#include "hal/modbus_cmm.hpp"
#include "sim/simulated_cmm.hpp"

namespace cmm::daemon {

std::unique_ptr<hal::Cmm> make_driver(const std::string& driver, const std::string& base_dir) {
  if (driver == "sim") return std::make_unique<sim::SimulatedCmm>(base_dir);
  if (driver == "modbus") return std::make_unique<hal::ModbusCmm>();
  if (driver == "grbl" || driver == "serial") return std::make_unique<hal::GrblCmm>();
  throw std::invalid_argument("unknown machine driver \"" + driver + "\" (known: sim, modbus, grbl)");
}

}  // namespace cmm::daemon
