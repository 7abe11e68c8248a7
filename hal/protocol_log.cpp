// The protocol log's lines; see protocol_log.hpp.
#include "hal/protocol_log.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <stdexcept>

namespace cmm::hal {

ProtocolLog::ProtocolLog(const std::string& path) : out_(path, std::ios::app) {
  if (!out_) throw std::runtime_error("cannot open the protocol log " + path + " for appending");
}

void ProtocolLog::write(const char* direction, std::string_view line) {
  const auto now = std::chrono::system_clock::now();
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(now.time_since_epoch()).count();
  const std::time_t seconds = static_cast<std::time_t>(us / 1000000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char stamp[96];
  std::snprintf(stamp, sizeof stamp, "%04d-%02d-%02dT%02d:%02d:%02d.%06dZ", utc.tm_year + 1900, utc.tm_mon + 1,
                utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, static_cast<int>(us % 1000000));
  std::lock_guard lock(mutex_);
  out_ << stamp << ' ' << direction << ' ' << line << '\n';
  out_.flush();
}

}  // namespace cmm::hal
