// Fuzzes plate.json (planner/plate.hpp): plate_from_json on any JSON, and what it accepts written
// back and read again. Refusals: geometry::FileError naming the field.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "geometry/file_error.hpp"
#include "planner/plate.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = cmm::fuzz::json_of(cmm::fuzz::text_of(data, size));
  if (!j) return 0;
  cmm::fuzz::refusing_with<cmm::geometry::FileError>([&] {
    const cmm::planner::Plate plate = cmm::planner::plate_from_json(*j, "plate.json");
    (void)cmm::planner::plate_from_json(cmm::planner::to_json(plate), "plate.json (written back)");
  });
  return 0;
}
