// Time stamps as the HAL records them (qualification times): ISO 8601 UTC text, and the Unix
// seconds a wire protocol carries.
#pragma once

#include <cstdint>
#include <string>

namespace cmm::hal {

std::string utc_now();                          // "2026-11-24T12:00:00Z"
std::string utc_text(std::int64_t unix_seconds);
// Unix seconds of a "YYYY-MM-DDTHH:MM:SSZ" text; throws std::invalid_argument otherwise.
std::int64_t unix_seconds(const std::string& utc);

}  // namespace cmm::hal
