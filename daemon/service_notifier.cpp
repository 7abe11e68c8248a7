// sd_notify for cmmd: one datagram per state change, watchdog kicks from the event loop.
#include "daemon/service_notifier.hpp"

#include <systemd/sd-daemon.h>

#include <algorithm>
#include <cstdlib>

#include <asio/post.hpp>

namespace cmm::daemon {
namespace {

std::error_code notify(const std::string& state) {
  const int r = sd_notify(0, state.c_str());
  return r < 0 ? std::error_code(-r, std::generic_category()) : std::error_code();
}

std::string one_line(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

// A failed kick is not retried or reported: if the manager cannot hear us it restarts us,
// which is the right outcome for a daemon it cannot supervise.
void kick_and_rearm(const std::weak_ptr<asio::steady_timer>& weak, std::chrono::microseconds period) {
  const auto timer = weak.lock();
  if (!timer) return;
  notify("WATCHDOG=1");
  timer->expires_after(period);
  timer->async_wait([weak, period](const asio::error_code& ec) {
    if (!ec) kick_and_rearm(weak, period);
  });
}

}  // namespace

ServiceNotifier::ServiceNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  active_ = socket != nullptr && *socket != '\0';
  uint64_t usec = 0;
  // sd_watchdog_enabled checks WATCHDOG_PID against our pid, so a child that inherited the
  // environment does not kick on our behalf.
  if (active_ && sd_watchdog_enabled(0, &usec) > 0) watchdog_interval_ = std::chrono::microseconds(usec);
}

ServiceNotifier::~ServiceNotifier() { stop_watchdog(); }

std::error_code ServiceNotifier::ready(const std::string& status) {
  return active_ ? notify("READY=1\nSTATUS=" + one_line(status)) : std::error_code();
}

std::error_code ServiceNotifier::status(const std::string& status) {
  return active_ ? notify("STATUS=" + one_line(status)) : std::error_code();
}

std::error_code ServiceNotifier::reloading() {
  if (!active_) return {};
  // systemd 253's Type=notify-reload wants the time stamp; older managers ignore it.
  const auto now = std::chrono::duration_cast<std::chrono::microseconds>(
      std::chrono::steady_clock::now().time_since_epoch());
  return notify("RELOADING=1\nMONOTONIC_USEC=" + std::to_string(now.count()));
}

std::error_code ServiceNotifier::stopping() { return active_ ? notify("STOPPING=1") : std::error_code(); }

std::error_code ServiceNotifier::watchdog() { return active_ ? notify("WATCHDOG=1") : std::error_code(); }

void ServiceNotifier::start_watchdog(asio::io_context& io) {
  if (watchdog_interval_.count() == 0) return;
  stop_watchdog();
  timer_ = std::make_shared<asio::steady_timer>(io);
  const std::weak_ptr<asio::steady_timer> weak = timer_;
  asio::post(io, [weak, period = watchdog_interval_ / 2] { kick_and_rearm(weak, period); });
}

void ServiceNotifier::stop_watchdog() { timer_.reset(); }

}  // namespace cmm::daemon
