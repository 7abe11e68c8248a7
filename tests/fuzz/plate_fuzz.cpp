// Fuzzes plate.json (hal/description/plate.hpp): plate_from_json on any JSON, and what it accepts
// written back and read again. Refusals: description::FieldError naming the fields.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "hal/description/json_fields.hpp"
#include "hal/description/plate.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = cmm::fuzz::json_of(cmm::fuzz::text_of(data, size));
  if (!j) return 0;
  cmm::fuzz::refusing_with<cmm::description::FieldError>([&] {
    const cmm::description::Plate plate = cmm::description::plate_from_json(*j, "plate.json");
    (void)cmm::description::plate_from_json(cmm::description::to_json(plate), "plate.json (written back)");
  });
  return 0;
}
