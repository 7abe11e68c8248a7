// Fuzzes the Modbus decode (hal/modbus_status.hpp, hal/modbus_map.hpp): any register values as a
// machine might answer them, through decode_status, decode_touch, decode_tip, get_ascii and
// fault_from_code, on blocks of the size the driver reads and on short ones. Refusals: hal::Fault
// (Protocol: a short block, an unknown fault code).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "hal/fault.hpp"
#include "hal/modbus_map.hpp"
#include "hal/modbus_status.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace mb = cmm::hal::modbus;
  using cmm::fuzz::refusing_with;
  using cmm::hal::Fault;
  // Registers as they come off the wire, high byte first.
  std::vector<std::uint16_t> regs(size / 2);
  for (std::size_t i = 0; i < regs.size(); ++i)
    regs[i] = static_cast<std::uint16_t>(data[2 * i] << 8 | data[2 * i + 1]);
  const std::span<const std::uint16_t> all(regs);
  static const std::vector<std::string> tips = {"T1", "T2", "T3"};
  refusing_with<Fault>([&] { (void)mb::decode_status(all, tips); });
  refusing_with<Fault>([&] { (void)mb::decode_touch(all, tips); });
  refusing_with<Fault>([&] { (void)mb::decode_tip(all); });
  // The tip entry after the status block, then the fault text, as one answer each.
  const auto rest = all.subspan(std::min<std::size_t>(all.size(), mb::kStatusCount));
  refusing_with<Fault>([&] { (void)mb::decode_tip(rest); });
  (void)mb::get_ascii(rest.data(), static_cast<int>(std::min<std::size_t>(rest.size(), 64)));
  // Any register read as a fault code (done_result, fault_code); the status block's worth is enough.
  for (const std::uint16_t code : all.first(std::min<std::size_t>(all.size(), mb::kStatusCount)))
    refusing_with<Fault>([&] { (void)mb::fault_from_code(code); });
  return 0;
}
