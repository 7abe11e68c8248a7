// A stand-in for systemd's notify socket: an AF_UNIX datagram socket in a test folder that keeps
// what a service sends with sd_notify (READY=1, STATUS=…, WATCHDOG=1, STOPPING=1), in order.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace cmm::testing {

class NotifyListener {
 public:
  explicit NotifyListener(std::filesystem::path socket_path);  // binds it; the path must not exist
  ~NotifyListener();
  NotifyListener(const NotifyListener&) = delete;
  NotifyListener& operator=(const NotifyListener&) = delete;

  const std::filesystem::path& path() const { return path_; }

  // The next datagram, or nothing within timeout_s.
  std::optional<std::string> receive(double timeout_s);
  // Receives until a datagram with a line that starts with `prefix` (e.g. "READY=1", "STATUS=")
  // arrives and returns that datagram; throws std::runtime_error, listing what did arrive, after timeout_s.
  std::string wait_for(const std::string& prefix, double timeout_s);
  // Every datagram received so far.
  const std::vector<std::string>& received() const { return received_; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  std::vector<std::string> received_;
};

// The lines of a datagram ("READY=1\nSTATUS=…" → {"READY=1", "STATUS=…"}).
std::vector<std::string> notify_lines(const std::string& datagram);

// A launcher for CmmdInstance::start: a shell that sets NOTIFY_SOCKET, WATCHDOG_USEC and
// WATCHDOG_PID (its own pid, which cmmd keeps across exec, as systemd would set it) and execs cmmd.
std::vector<std::string> notify_launcher(const NotifyListener& listener, long watchdog_usec);

}  // namespace cmm::testing
