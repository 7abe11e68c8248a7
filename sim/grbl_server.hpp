// cmm-sim's serial side: serves one SimulatedMachine in the Grbl 1.1 dialect (hal/grbl_protocol.hpp,
// docs/hal.md "Grbl 1.1 dialect") over a pty it creates or a serial device it is given, with the
// link faults of the config (drop, delay, corrupt) injected on the line.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <thread>

#include "hal/grbl_protocol.hpp"
#include "sim/simulated_machine.hpp"

namespace cmm::sim {

class GrblServer {
 public:
  // device empty: creates a pty (slave_path() names it); otherwise opens the device (raw mode).
  // Throws std::runtime_error naming the device when it cannot.
  GrblServer(SimulatedMachine& machine, const FaultInjection& faults, const std::string& device = "");
  ~GrblServer();
  GrblServer(const GrblServer&) = delete;
  GrblServer& operator=(const GrblServer&) = delete;

  const std::string& slave_path() const { return path_; }
  void serve();     // the receive loop, until shutdown(); from one thread
  void shutdown();  // from any thread

 private:
  void open_line();
  void receive(char byte);
  void write_line(const std::string& line);
  void status_report();
  void feed_hold();
  void soft_reset();
  void worker_loop();
  void execute(const std::string& line, std::uint64_t generation);
  std::string settings_report() const;
  // The reply that ends a line, unless a soft reset has flushed the line meanwhile.
  // `command` is the motion line's number (0 for other lines): the link faults apply to motion lines.
  void reply(const std::string& text, std::uint64_t generation, int command);
  void emit(const std::string& text, std::uint64_t generation);  // a message line before the reply
  bool begin_motion(int& command, bool homing);  // counts the line; false when the link drops instead
  void fault(const hal::Fault& f, std::uint64_t generation, int command, bool probe);

  SimulatedMachine& machine_;
  FaultInjection faults_;
  std::string device_, path_;
  int fd_ = -1;
  std::atomic<bool> running_{true};
  std::mutex write_mutex_;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::string> lines_;  // received, not yet executed
  std::string partial_;
  std::size_t queued_bytes_ = 0;
  std::uint64_t generation_ = 0;  // bumped by a soft reset: replies of older lines are dropped
  bool busy_ = false, in_motion_ = false, homing_ = false, hold_ = false, held_ = false;
  int alarm_ = 0;
  int commands_ = 0;
  bool dropped_ = false, drop_now_ = false;
  double feed_mm_min_ = 0;
  hal::grbl::ProbeReport last_probe_;
  std::thread worker_;
};

}  // namespace cmm::sim
