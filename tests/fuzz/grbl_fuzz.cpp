// Fuzzes the Grbl replies (hal/grbl_protocol.hpp) as the serial driver meets them: bytes split into
// lines as GrblCmm's reader does ('\n' ends a line, '\r' is dropped), each line through parse_status,
// parse_probe, parse_error and parse_alarm and a code through its fault and text. The reader and the
// reply classification of GrblCmm::transact need a port, so the split is mirrored here. The parsers
// refuse with nullopt; what they accept must be finite, as the driver computes with it.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "hal/grbl_protocol.hpp"

namespace {

void check(bool ok) {
  if (!ok) __builtin_trap();
}

void on_line(const std::string& line) {
  using namespace cmm::hal::grbl;
  if (const auto status = parse_status(line)) {
    check(!status->state.empty() && status->mpos.allFinite() && std::isfinite(status->feed_mm_min));
    check(!status->clock_s || std::isfinite(*status->clock_s));
  }
  if (const auto probe = parse_probe(line)) check(probe->position.allFinite());
  if (const auto code = parse_error(line)) {
    (void)fault_from_error(*code);
    (void)error_text(*code);
  }
  if (const auto code = parse_alarm(line)) {
    (void)fault_from_alarm(*code);
    (void)alarm_text(*code);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string partial;
  for (const char c : cmm::fuzz::text_of(data, size)) {
    if (c == '\n') {
      on_line(partial);
      partial.clear();
    } else if (c != '\r') {
      partial.push_back(c);
    }
  }
  return 0;
}
