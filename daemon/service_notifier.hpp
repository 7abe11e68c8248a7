// Telling systemd how cmmd is doing (sd_notify): ready, status, reloading, stopping, and watchdog
// kicks driven by the Asio event loop; without NOTIFY_SOCKET (cmmd run by hand) it does nothing.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <system_error>

#include <asio/io_context.hpp>
#include <asio/steady_timer.hpp>

namespace cmm::daemon {

class ServiceNotifier {
 public:
  // Reads NOTIFY_SOCKET, WATCHDOG_USEC and WATCHDOG_PID once; construct it after the
  // environment is final.
  ServiceNotifier();
  ~ServiceNotifier();
  ServiceNotifier(const ServiceNotifier&) = delete;
  ServiceNotifier& operator=(const ServiceNotifier&) = delete;

  // True when a service manager listens (NOTIFY_SOCKET is set).
  bool active() const { return active_; }

  // Each send returns the errno of a failed send to NOTIFY_SOCKET, and no error when the
  // message went out or nobody listens. A newline in `status` becomes a space: it would
  // otherwise start another assignment.
  std::error_code ready(const std::string& status);  // READY=1 + STATUS
  std::error_code status(const std::string& status);  // STATUS only: the machine link's state goes here
  std::error_code reloading();                        // RELOADING=1; send ready() when done
  std::error_code stopping();                         // STOPPING=1
  std::error_code watchdog();                         // WATCHDOG=1

  // systemd's WatchdogSec for this process; zero without a watchdog, without a manager, or
  // when WATCHDOG_PID names another process.
  std::chrono::microseconds watchdog_interval() const { return watchdog_interval_; }

  // Kicks the watchdog from `io` at half the interval, so the kicks stop when the event loop
  // stops turning (a handler that blocks): systemd then restarts cmmd. Only the loop's health
  // feeds the watchdog, never the machine's. A no-op without a watchdog; the first kick is
  // posted, so it too comes from the loop. Destroy the notifier (or stop_watchdog()) before
  // `io`; call both from the loop's thread or while it is not running (timers are not
  // thread-safe).
  void start_watchdog(asio::io_context& io);
  void stop_watchdog();

 private:
  bool active_ = false;
  std::chrono::microseconds watchdog_interval_{0};
  // Shared with the timer's handlers only as a weak_ptr: a handler that runs after stop_watchdog()
  // (or the notifier's end) finds it gone and stops, instead of touching a dead object.
  std::shared_ptr<asio::steady_timer> timer_;
};

}  // namespace cmm::daemon
