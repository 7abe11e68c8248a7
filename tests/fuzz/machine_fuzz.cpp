// Fuzzes machine.json (hal/description/machine_description.hpp): machine_from_json on any JSON, and
// what it accepts written back and read again. Refusals: description::FieldError naming the fields.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "hal/description/json_fields.hpp"
#include "hal/description/machine_description.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = cmm::fuzz::json_of(cmm::fuzz::text_of(data, size));
  if (!j) return 0;
  cmm::fuzz::refusing_with<cmm::description::FieldError>([&] {
    const cmm::description::MachineDescription m = cmm::description::machine_from_json(*j, "machine.json");
    // What it accepted, it writes so that it reads back.
    (void)cmm::description::machine_from_json(cmm::description::to_json(m), "machine.json (written back)");
  });
  return 0;
}
