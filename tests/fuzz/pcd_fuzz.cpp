// Fuzzes the PCD reader (geometry/pcd_io.hpp): read_pcd on any bytes, as a model upload or a file on
// disk reaches it, in every DATA encoding (the LZF decoder of binary_compressed included), and what it
// accepts checked against the readers' promises (model_check.hpp). Refusals: geometry::FileError
// naming the line or byte.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "model_check.hpp"
#include "geometry/file_error.hpp"
#include "geometry/pcd_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  cmm::fuzz::refusing_with<cmm::geometry::FileError>(
      [&] { cmm::fuzz::check_model(cmm::geometry::read_pcd("fuzz.pcd", cmm::fuzz::text_of(data, size))); });
  return 0;
}
