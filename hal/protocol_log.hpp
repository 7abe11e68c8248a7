// A protocol log for a wire link (the I++ DME client and server): every line sent or received,
// with a UTC time stamp to the microsecond and its direction, for debugging against a real
// controller. One file, appended to, flushed line by line so that a crash keeps the last lines.
#pragma once

#include <fstream>
#include <mutex>
#include <string>
#include <string_view>

namespace cmm::hal {

class ProtocolLog {
 public:
  // Throws std::runtime_error naming the file when it cannot be opened for appending.
  explicit ProtocolLog(const std::string& path);
  void sent(std::string_view line) { write("->", line); }      // "2026-12-03T12:00:00.123456Z -> 00001 Home()"
  void received(std::string_view line) { write("<-", line); }  // "… <- 00001 &"
  void note(std::string_view text) { write("--", text); }      // connects, drops, half lines

 private:
  void write(const char* direction, std::string_view line);
  std::mutex mutex_;
  std::ofstream out_;
};

}  // namespace cmm::hal
