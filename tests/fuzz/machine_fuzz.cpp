// Fuzzes machine.json (planner/machine.hpp): machine_from_json on any JSON, and what it accepts
// written back and read again. Refusals: geometry::FileError naming the field.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "geometry/file_error.hpp"
#include "planner/machine.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = cmm::fuzz::json_of(cmm::fuzz::text_of(data, size));
  if (!j) return 0;
  cmm::fuzz::refusing_with<cmm::geometry::FileError>([&] {
    const cmm::planner::MachineDescription m = cmm::planner::machine_from_json(*j, "machine.json");
    // What it accepted, it writes so that it reads back.
    (void)cmm::planner::machine_from_json(cmm::planner::to_json(m), "machine.json (written back)");
  });
  return 0;
}
