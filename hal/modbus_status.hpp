// What a Modbus machine reports, decoded from its registers as hal/modbus_map.hpp lays them out: the
// status block (with the last touch in it) and one tip table entry. Free functions on the register
// values alone, so the driver and the fuzz harness (tests/fuzz/) decode the same way.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "hal/description/machine_description.hpp"
#include "hal/machine_status.hpp"
#include "hal/modbus_map.hpp"
#include "hal/motion.hpp"

namespace cmm::hal::modbus {

// `status` is the status block from register kStatusFirst (kStatusCount registers); `tip_ids` is the
// machine's tip table, which names the active tip. The lifecycle and the fault's message are the
// driver's to fill in. Throws Protocol for a short block or an unknown fault code.
MachineStatus decode_status(std::span<const std::uint16_t> status, const std::vector<std::string>& tip_ids);
// The last probe's result in the same block: without contact, the centre is where the search ended.
TouchResult decode_touch(std::span<const std::uint16_t> status, const std::vector<std::string>& tip_ids);
// One entry of the tip table, kTipEntryCount registers from its tip_id (entries are kTipStride
// apart); throws Protocol when short.
inline constexpr std::uint16_t kTipEntryCount = address("tip_touches") + 1 - address("tip_id");
description::StylusTip decode_tip(std::span<const std::uint16_t> entry);

}  // namespace cmm::hal::modbus
