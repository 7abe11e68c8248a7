// cmm-sim's Modbus TCP side: serves one SimulatedMachine through the register map of
// hal/modbus_map.hpp, with the link faults of the config (drop, delay, corrupt) injected on the wire.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <modbus/modbus.h>

#include "hal/motion.hpp"
#include "sim/simulated_machine.hpp"

namespace cmm::sim {

class ModbusServer {
 public:
  // Listens on host:port at once (port 0: any free port; port() tells which). Throws
  // std::runtime_error naming the address when it cannot.
  ModbusServer(SimulatedMachine& machine, const FaultInjection& faults, const std::string& host, int port);
  ~ModbusServer();
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  int port() const { return port_; }
  void serve();     // the request loop, until shutdown(); from one thread
  void shutdown();  // from any thread (a signal handler should set a flag and call it from elsewhere)

 private:
  struct Command {
    std::uint16_t seq = 0;
    std::vector<std::uint16_t> block;
  };
  void handle(int fd, const std::uint8_t* query, int length);
  void refresh();  // machine state into the registers, before every reply
  void execute(const Command& command);
  void worker_loop();
  void drop_clients();
  void watch_heartbeat();

  SimulatedMachine& machine_;
  FaultInjection faults_;
  modbus_t* ctx_ = nullptr;
  modbus_mapping_t* map_ = nullptr;
  int listen_fd_ = -1;
  int port_ = 0;
  std::vector<int> clients_;
  std::atomic<bool> running_{true};
  int commands_ = 0;
  bool dropped_ = false;
  std::uint16_t last_seq_ = 0;
  std::chrono::steady_clock::time_point last_heartbeat_;

  // Shared with the worker that runs commands on the machine.
  std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<Command> pending_;
  bool busy_ = false, stale_stop_ = false, stale_ = false;
  std::uint16_t done_seq_ = 0, done_result_ = 0;
  std::string done_message_;
  hal::TouchResult touch_;
  std::thread worker_;
};

}  // namespace cmm::sim
