// Fuzzes cmmd.json (daemon/daemon_config.hpp): the whole file through daemon_config_from_json, and
// its machine block through the reader of the driver it names (sim, Modbus, Grbl, I++ DME), as cmmd does at
// start and on SIGHUP. Refusals: description::FieldError listing the bad keys.
#include <cstddef>
#include <cstdint>

#include "daemon/daemon_config.hpp"
#include "fuzz_support.hpp"
#include "hal/description/json_fields.hpp"
#include "hal/grbl_cmm.hpp"
#include "hal/ippdme_cmm.hpp"
#include "hal/modbus_cmm.hpp"
#include "sim/sim_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = cmm::fuzz::json_of(cmm::fuzz::text_of(data, size));
  if (!j || cmm::fuzz::names_special_file(*j)) return 0;
  cmm::fuzz::refusing_with<cmm::description::FieldError>([&] {
    const cmm::daemon::DaemonConfig c = cmm::daemon::daemon_config_from_json(*j, "cmmd.json", "/nonexistent");
    (void)cmm::daemon::changes_needing_restart(c, c);
    // What the driver factory's configure() reads from the block.
    if (c.driver == "modbus") (void)cmm::hal::modbus_settings_from_json(c.machine);
    if (c.driver == "grbl") (void)cmm::hal::grbl_settings_from_json(c.machine);
    if (c.driver == "ippdme") (void)cmm::hal::ippdme_settings_from_json(c.machine, "/nonexistent");
    if (c.driver == "sim") (void)cmm::sim::sim_config_from_json(c.machine, "/nonexistent");
  });
  return 0;
}
