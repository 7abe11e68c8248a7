// hal::Cmm over a serial line speaking Grbl 1.1 (hal/grbl_protocol.hpp; docs/hal.md "Grbl 1.1
// dialect"): guarded travel and searches as G38.3/G38.2 in machine coordinates, status by the
// real-time `?`, stop as feed hold then soft reset, and the machine description kept driver-side.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "hal/cmm_driver.hpp"
#include "hal/grbl_protocol.hpp"

namespace cmm::hal {

struct GrblSettings {
  std::string device;
  int baud = 115200;
  bool reset_on_open = true;       // opening the port pulses DTR, which resets an Arduino-class board
  double reset_wait_s = 2;         // how long to wait for the banner after that reset
  double response_timeout_s = 1;   // a non-motion line's answer; a motion's ok once the machine is idle
  double status_timeout_s = 0.5;   // a `?` unanswered this long means the link is gone (CommLost)
  double motion_timeout_s = 600;   // one motion line, from sending it to its ok
  double poll_interval_s = 0.01;   // `?` while a motion runs
  int connect_attempts = 4;
  double connect_backoff_s = 0.05;  // doubled after each failed attempt
  // What Grbl does not know: the machine's description ("machine": machine.json inline or its file
  // name; the built-in config/machine.json without one).
  description::MachineDescription machine = description::default_machine();
};

// Relative file names in the block resolve against `base_dir`. Throws description::FieldError.
GrblSettings grbl_settings_from_json(const nlohmann::json& block, const std::string& base_dir = ".");

class GrblCmm : public CmmDriver {
 public:
  explicit GrblCmm(std::string base_dir = ".");
  ~GrblCmm() override;

  std::optional<description::MachineDescription> configured_machine() const override;

 protected:
  ConnectPolicy connect_policy() const override;
  std::string where() const override;
  void on_configure(const nlohmann::json& block) override;
  void on_connect() override;
  void on_disconnect() override;
  description::MachineDescription read_info() override;
  MachineStatus read_status() override;
  void begin_motion() override;
  void do_home() override;
  void do_move(const Move& move) override;
  TouchResult do_probe(const ProbeMove& move) override;
  void do_stop() override;
  void do_abort() override;
  void do_reset() override;
  void do_select_tip(const std::string& tip_id) override;
  void do_record_qualification(const std::string& tip_id, const description::TipQualification& q) override;

 private:
  struct Port;  // the Asio serial port and its reader thread
  struct LineResult {
    std::vector<std::string> messages;  // [PRB:…], [MSG:…] before the ok
    std::optional<grbl::ProbeReport> probe;
  };
  void send(const std::string& bytes, const char* what);
  void on_line(const std::string& line);
  void on_link_down();
  grbl::StatusReport query_status(const char* what);
  // Sends one line (counting into Grbl's RX buffer) and waits for its ok; error:N and ALARM:N throw.
  LineResult transact(const std::string& line, const char* what, bool motion);
  [[noreturn]] void alarm(int code, const char* what);
  // The link is out of step (a line's answer may still come): down until connect().
  void link_out_of_step();
  // At connect: a line still running (or whose answer this driver gave up on) is brought to rest
  // and flushed, so that its ok cannot answer the next line. Returns the status after.
  grbl::StatusReport flush_old_line(grbl::StatusReport s);
  void setup_modes();
  const description::StylusTip& active() const;
  Vec3 mpos_of(const Vec3& ball) const { return ball - active().offset; }
  std::optional<grbl::ProbeReport> guarded(const Vec3& ball_target, double speed_mm_s, bool fail_on_miss, const char* what);
  void close_port();

  std::string base_dir_;
  GrblSettings settings_;
  std::unique_ptr<Port> port_;
  std::mutex line_mutex_;  // one line in flight at a time
  std::mutex write_mutex_;  // one writer on the descriptor; close_port() waits for it

  mutable std::mutex mutex_;  // what the reader thread hands over
  std::condition_variable wake_;
  std::deque<std::string> replies_;
  std::optional<grbl::StatusReport> last_status_;
  std::uint64_t status_seq_ = 0;
  bool link_down_ = false;
  std::size_t in_flight_bytes_ = 0;
  std::atomic<bool> unanswered_{false};  // a line was sent whose final answer never came

  std::atomic<bool> stop_requested_{false}, abort_requested_{false};
  std::size_t active_ = 0;
};

}  // namespace cmm::hal
