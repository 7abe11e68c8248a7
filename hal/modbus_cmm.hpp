// hal::Cmm over Modbus (TCP or RTU) with libmodbus, speaking the register map of
// hal/modbus_map.hpp: one atomic command block per motion, its sequence echo, a heartbeat.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <modbus/modbus.h>

#include "hal/cmm_driver.hpp"
#include "hal/fault.hpp"

namespace cmm::hal {

struct ModbusSettings {
  std::string transport = "tcp";  // tcp | rtu
  std::string host = "127.0.0.1";
  int port = 502;
  std::string device;  // rtu
  int baud = 115200;
  std::string parity = "N";  // N | E | O
  int unit_id = 1;
  double response_timeout_s = 1;   // one request's answer
  double motion_timeout_s = 600;   // one command, from the write to the machine's echo
  double poll_interval_s = 0.002;  // while waiting for the echo
  double heartbeat_s = 0.1;        // 0: no heartbeat
  double heartbeat_timeout_s = 1;  // the machine stops when the heartbeat is this old
  int connect_attempts = 4;
  double connect_backoff_s = 0.05;  // doubled after each failed attempt
};

ModbusSettings modbus_settings_from_json(const nlohmann::json& block);  // throws description::FieldError

// Threads: the motion calls use one context; status(), stop() and abort() use a second one (TCP)
// so they answer while a motion runs. On RTU there is one line and one context, shared under a
// lock that the motion thread drops between polls.
//
// A request left unanswered (Timeout) may still be answered later, and a reply that belongs to
// another request (Protocol) shows that one already was: either way the context is out of step, so
// the driver closes the link and drops to configured, as for CommLost; connect() opens it afresh and
// re-reads the machine.
class ModbusCmm : public CmmDriver {
 public:
  ModbusCmm();
  ~ModbusCmm() override;

 protected:
  ConnectPolicy connect_policy() const override;
  std::string where() const override;
  void on_configure(const nlohmann::json& block) override;
  void on_connect() override;
  void on_disconnect() override;
  description::MachineDescription read_info() override;
  MachineStatus read_status() override;
  void do_home() override;
  void do_move(const Move& move) override;
  TouchResult do_probe(const ProbeMove& move) override;
  void do_stop() override;
  void do_abort() override;
  void do_reset() override;
  void do_select_tip(const std::string& tip_id) override;
  void do_record_qualification(const std::string& tip_id, const description::TipQualification& q) override;

 private:
  // A context and its lock; the context is read only under the lock, so a disconnect on another
  // thread cannot free it under a request.
  struct Link {
    modbus_t** ctx = nullptr;
    std::mutex* mutex = nullptr;
  };
  std::string endpoint() const;  // host:port, or the serial device
  modbus_t* open_context() const;
  void close_contexts();
  // One request on `link` under its lock: `request(ctx)` is true when it got its answer. With
  // `even_if_down` it is sent on a context still open after the link was dropped (the last stop).
  template <class Request>
  void exchange(Link link, const char* what, Request&& request, bool even_if_down = false);
  // Maps a failed request's errno to Timeout, Protocol or CommLost; closes `ctx` and drops the link
  // unless the machine answered this very request (an exception reply, a bad CRC).
  [[noreturn]] void request_failed(modbus_t*& ctx, const char* what, int error);
  [[noreturn]] void link_is_down(const char* what) const;  // the fault that took the link down, again
  std::vector<std::uint16_t> read(Link link, int address, int count, const char* what);
  void write_single(Link link, int address, std::uint16_t value, const char* what, bool even_if_down = false);
  // Writes one command block, waits for its echo and returns the status block read with it.
  std::vector<std::uint16_t> run_command(std::vector<std::uint16_t> block, const char* what, bool motion);
  MachineStatus decode_status(const std::vector<std::uint16_t>& regs) const;
  int tip_index(const std::string& id);
  void heartbeat_loop();
  void stop_heartbeat();
  Link command_link() { return {&command_ctx_, &command_mutex_}; }
  Link aux_link() { return settings_.transport == "rtu" ? command_link() : Link{&aux_ctx_, &aux_mutex_}; }

  ModbusSettings settings_;
  modbus_t* command_ctx_ = nullptr;
  modbus_t* aux_ctx_ = nullptr;  // null on RTU
  std::mutex command_mutex_, aux_mutex_;
  mutable std::mutex down_mutex_;
  std::optional<std::pair<FaultKind, std::string>> down_;  // why the link was dropped, until connect()
  std::uint16_t seq_ = 0;
  std::vector<std::string> tip_ids_;  // the machine's tip table, read at connect and by info()
  mutable std::mutex tips_mutex_;     // info() writes tip_ids_ while status() may read it
  std::thread heartbeat_;
  std::mutex heartbeat_mutex_;
  std::condition_variable heartbeat_wake_;
  bool heartbeat_stop_ = false;
};

}  // namespace cmm::hal
