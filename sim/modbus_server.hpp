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

// Where the server answers: Modbus TCP on an address, or Modbus RTU (unit 1, 8N1) on a serial device.
struct ModbusTcpEndpoint {
  std::string host = "127.0.0.1";
  int port = 0;  // 0: any free port
};
struct ModbusRtuEndpoint {
  std::string device;
  int baud = 115200;
};

class ModbusServer {
 public:
  // Listens (TCP) or opens the device (RTU) at once; port() tells a TCP port chosen by the system.
  // Throws std::runtime_error naming the address or device when it cannot.
  ModbusServer(SimulatedMachine& machine, const FaultInjection& faults, const ModbusTcpEndpoint& endpoint);
  ModbusServer(SimulatedMachine& machine, const FaultInjection& faults, const ModbusRtuEndpoint& endpoint);
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
  void start();
  void drop_clients();
  void serve_rtu(std::uint8_t* query);
  void watch_heartbeat();

  SimulatedMachine& machine_;
  FaultInjection faults_;
  modbus_t* ctx_ = nullptr;
  modbus_mapping_t* map_ = nullptr;
  int listen_fd_ = -1;  // TCP
  bool rtu_ = false;
  bool silent_ = false;  // RTU after a dropped link: a pulled cable answers nothing
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
  bool busy_ = false, stale_stop_ = false, stale_ = false, stop_pending_ = false;
  std::uint16_t done_seq_ = 0, done_result_ = 0;
  std::string done_message_;
  hal::TouchResult touch_;
  std::thread worker_;
};

}  // namespace cmm::sim
