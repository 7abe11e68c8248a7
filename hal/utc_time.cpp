// ISO 8601 UTC text ↔ Unix seconds, with the C library's gmtime_r and timegm.
#include "hal/utc_time.hpp"

#include <chrono>
#include <ctime>
#include <stdexcept>

namespace cmm::hal {

std::string utc_text(std::int64_t unix_seconds) {
  const auto t = static_cast<std::time_t>(unix_seconds);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

std::string utc_now() {
  return utc_text(std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

std::int64_t unix_seconds(const std::string& utc) {
  std::tm tm{};
  char tail = 0;
  if (std::sscanf(utc.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d%c", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour, &tm.tm_min,
                  &tm.tm_sec, &tail) != 7 || tail != 'Z' || utc.size() != 20)
    throw std::invalid_argument("not a UTC time stamp (YYYY-MM-DDTHH:MM:SSZ): \"" + utc + "\"");
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return static_cast<std::int64_t>(timegm(&tm));
}

}  // namespace cmm::hal
