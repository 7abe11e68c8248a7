// ServiceNotifier against a fake systemd: a datagram socket in a temp folder named by NOTIFY_SOCKET,
// checking what arrives (ready, status, watchdog kicks from a running loop, none from a blocked one).
#include "daemon/service_notifier.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <future>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>

#include <asio/executor_work_guard.hpp>
#include <asio/post.hpp>
#include <gtest/gtest.h>

#include "fresh_folder.hpp"

namespace cmm::daemon {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// What systemd would listen on: an AF_UNIX datagram socket bound in a fresh folder.
class FakeNotifySocket {
 public:
  FakeNotifySocket() {
    folder_ = fresh_folder("notify");
    path_ = folder_ / "notify";
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "socket(AF_UNIX, SOCK_DGRAM)");
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    const std::string p = path_.string();
    if (p.size() >= sizeof addr.sun_path) throw std::runtime_error("socket path too long: " + p);
    p.copy(addr.sun_path, p.size());
    if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0)
      throw std::system_error(errno, std::generic_category(), "bind " + p);
  }
  ~FakeNotifySocket() {
    ::close(fd_);
    std::error_code ignored;
    fs::remove_all(folder_, ignored);
  }
  FakeNotifySocket(const FakeNotifySocket&) = delete;
  FakeNotifySocket& operator=(const FakeNotifySocket&) = delete;

  const fs::path& path() const { return path_; }

  // The next datagram, or nothing if none arrives within `timeout`.
  std::optional<std::string> receive(std::chrono::milliseconds timeout) {
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(timeout.count()));
    if (ready < 0) throw std::system_error(errno, std::generic_category(), "poll " + path_.string());
    if (ready == 0) return std::nullopt;
    char buffer[4096];
    const ssize_t n = ::recv(fd_, buffer, sizeof buffer, MSG_DONTWAIT);
    if (n < 0) throw std::system_error(errno, std::generic_category(), "recv " + path_.string());
    return std::string(buffer, static_cast<std::size_t>(n));
  }

  // Everything already queued, dropped; returns how many datagrams that was.
  int drain() {
    int n = 0;
    while (receive(0ms)) ++n;
    return n;
  }

 private:
  fs::path folder_;
  fs::path path_;
  int fd_ = -1;
};

// Runs an io_context on its own thread until the end of the scope, so that a failed ASSERT
// cannot leave the thread joinable.
class LoopThread {
 public:
  explicit LoopThread(asio::io_context& io)
      : io_(io), work_(asio::make_work_guard(io)), thread_([&io] { io.run(); }) {}
  ~LoopThread() {
    io_.stop();
    thread_.join();
  }
  LoopThread(const LoopThread&) = delete;
  LoopThread& operator=(const LoopThread&) = delete;

 private:
  asio::io_context& io_;
  asio::executor_work_guard<asio::io_context::executor_type> work_;
  std::thread thread_;
};

// Each test sets the manager's environment itself; this puts the process's back afterwards.
class ServiceNotifierTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* name : {"NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID"}) ::unsetenv(name);
  }
  void TearDown() override { SetUp(); }

  void under_systemd(std::chrono::microseconds watchdog = 0us, pid_t watchdog_pid = getpid()) {
    ::setenv("NOTIFY_SOCKET", manager.path().c_str(), 1);
    if (watchdog.count() > 0) {
      ::setenv("WATCHDOG_USEC", std::to_string(watchdog.count()).c_str(), 1);
      ::setenv("WATCHDOG_PID", std::to_string(watchdog_pid).c_str(), 1);
    }
  }

  // Generous: these wait for something that must come, so only a failing test waits this long.
  static constexpr auto deadline = 5000ms;
  FakeNotifySocket manager;
};

TEST_F(ServiceNotifierTest, ReadyCarriesTheStatus) {
  under_systemd();
  ServiceNotifier notifier;
  EXPECT_TRUE(notifier.active());
  EXPECT_FALSE(notifier.ready("idle; machine simulator connected"));
  EXPECT_EQ(manager.receive(deadline), "READY=1\nSTATUS=idle; machine simulator connected");
}

TEST_F(ServiceNotifierTest, StatusUpdatesArriveInOrderOnOneLineEach) {
  under_systemd();
  ServiceNotifier notifier;
  EXPECT_FALSE(notifier.status("machine link lost"));
  EXPECT_FALSE(notifier.status("job 7 probing\nREADY=1"));
  EXPECT_EQ(manager.receive(deadline), "STATUS=machine link lost");
  // A newline in the text must not smuggle in another assignment.
  EXPECT_EQ(manager.receive(deadline), "STATUS=job 7 probing READY=1");
}

TEST_F(ServiceNotifierTest, ReloadingAndStopping) {
  under_systemd();
  ServiceNotifier notifier;
  EXPECT_FALSE(notifier.reloading());
  EXPECT_FALSE(notifier.stopping());
  const auto reloading = manager.receive(deadline);
  ASSERT_TRUE(reloading);
  EXPECT_EQ(reloading->rfind("RELOADING=1\nMONOTONIC_USEC=", 0), 0u) << *reloading;
  EXPECT_EQ(manager.receive(deadline), "STOPPING=1");
}

TEST_F(ServiceNotifierTest, WatchdogIntervalComesFromTheEnvironmentForThisProcessOnly) {
  under_systemd(2s);
  EXPECT_EQ(ServiceNotifier().watchdog_interval(), 2s);
  under_systemd(2s, getpid() + 1);
  EXPECT_EQ(ServiceNotifier().watchdog_interval(), 0us);
  ::unsetenv("WATCHDOG_USEC");
  ::unsetenv("WATCHDOG_PID");
  EXPECT_EQ(ServiceNotifier().watchdog_interval(), 0us);
}

TEST_F(ServiceNotifierTest, KicksArriveWhileTheLoopRuns) {
  under_systemd(20ms);
  asio::io_context io;
  ServiceNotifier notifier;
  notifier.start_watchdog(io);
  const LoopThread loop(io);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(manager.receive(deadline), "WATCHDOG=1") << "kick " << i;
}

TEST_F(ServiceNotifierTest, NoKicksWhileTheLoopIsBlocked) {
  under_systemd(20ms);
  asio::io_context io;
  ServiceNotifier notifier;
  notifier.start_watchdog(io);
  const LoopThread loop(io);
  ASSERT_EQ(manager.receive(deadline), "WATCHDOG=1");

  std::promise<void> entered;
  std::promise<void> release;
  asio::post(io, [&] {
    entered.set_value();
    release.get_future().wait();
  });
  entered.get_future().wait();
  // Kicks are sent from the loop's thread, so nothing sent before the block is still in flight.
  manager.drain();
  // Ten watchdog intervals of silence: a kick from anywhere but the loop would show up here.
  EXPECT_EQ(manager.receive(200ms), std::nullopt);
  release.set_value();
  EXPECT_EQ(manager.receive(deadline), "WATCHDOG=1");
}

TEST_F(ServiceNotifierTest, StoppedWatchdogSendsNoMoreKicks) {
  under_systemd(20ms);
  asio::io_context io;
  ServiceNotifier notifier;
  notifier.start_watchdog(io);
  EXPECT_EQ(io.run_one(), 1u);  // the posted first kick
  EXPECT_EQ(manager.receive(deadline), "WATCHDOG=1");
  notifier.stop_watchdog();
  io.run();  // returns once the cancelled wait is delivered; a re-armed timer would keep it going
  EXPECT_EQ(manager.drain(), 0);
}

TEST_F(ServiceNotifierTest, SilentWithoutNotifySocket) {
  ::setenv("WATCHDOG_USEC", "20000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  ServiceNotifier notifier;
  EXPECT_FALSE(notifier.active());
  EXPECT_EQ(notifier.watchdog_interval(), 0us);
  EXPECT_FALSE(notifier.ready("idle"));
  EXPECT_FALSE(notifier.status("idle"));
  EXPECT_FALSE(notifier.reloading());
  EXPECT_FALSE(notifier.stopping());
  EXPECT_FALSE(notifier.watchdog());
  asio::io_context io;
  notifier.start_watchdog(io);
  EXPECT_EQ(io.run(), 0u);  // nothing was armed
  EXPECT_EQ(manager.drain(), 0);
}

TEST_F(ServiceNotifierTest, AFailedSendIsReturnedNotThrown) {
  ::setenv("NOTIFY_SOCKET", (manager.path().parent_path() / "nobody-listens").c_str(), 1);
  ServiceNotifier notifier;
  const std::error_code error = notifier.ready("idle");
  EXPECT_TRUE(error == std::errc::no_such_file_or_directory || error == std::errc::connection_refused)
      << error.message();
}

}  // namespace
}  // namespace cmm::daemon
