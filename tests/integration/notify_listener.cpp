// The fake notify socket: bind, poll() with a deadline, recv one datagram at a time.
#include "notify_listener.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace cmm::testing {

NotifyListener::NotifyListener(std::filesystem::path socket_path) : path_(std::move(socket_path)) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path_.string().size() >= sizeof address.sun_path) throw std::runtime_error(path_.string() + ": path too long");
  std::strncpy(address.sun_path, path_.c_str(), sizeof address.sun_path - 1);
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error("socket: " + std::string(std::strerror(errno)));
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const int error = errno;
    ::close(fd_);
    throw std::runtime_error("bind " + path_.string() + ": " + std::strerror(error));
  }
}

NotifyListener::~NotifyListener() {
  ::close(fd_);
  std::error_code ignored;
  std::filesystem::remove(path_, ignored);
}

std::optional<std::string> NotifyListener::receive(double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::max<long long>(left, 0)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) return std::nullopt;
    char buffer[4096];
    const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
    if (n < 0) throw std::runtime_error("recv on " + path_.string() + ": " + std::strerror(errno));
    received_.emplace_back(buffer, static_cast<std::size_t>(n));
    return received_.back();
  }
}

std::string NotifyListener::wait_for(const std::string& prefix, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    const std::optional<std::string> datagram = receive(std::max(left, 0.0));
    if (!datagram) {
      std::string seen;
      for (const std::string& d : received_) seen += "\n  " + d;
      throw std::runtime_error("no \"" + prefix + "…\" on " + path_.string() + " within the timeout; received:" + seen);
    }
    for (const std::string& line : notify_lines(*datagram))
      if (line.rfind(prefix, 0) == 0) return *datagram;
  }
}

std::vector<std::string> notify_lines(const std::string& datagram) {
  std::vector<std::string> lines;
  std::istringstream in(datagram);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> notify_launcher(const NotifyListener& listener, long watchdog_usec) {
  return {"/bin/sh", "-c", "export NOTIFY_SOCKET=\"$1\" WATCHDOG_USEC=\"$2\" WATCHDOG_PID=$$; shift 2; exec \"$@\"", "sh",
          listener.path().string(), std::to_string(watchdog_usec)};
}

}  // namespace cmm::testing
