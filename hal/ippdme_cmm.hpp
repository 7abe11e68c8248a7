// hal::Cmm as an I++ DME client (VDMA 8722; hal/ippdme_protocol.hpp, docs/ippdme.md): a commercial
// CMM controller's I++ server on TCP, driven with GoTo and PtMeas, watched by a move-report daemon,
// stopped with AbortE, its errors recovered with ClearAllErrors; the machine description is kept on
// this side, as for Grbl.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "hal/cmm_driver.hpp"
#include "hal/ippdme_protocol.hpp"
#include "hal/protocol_log.hpp"

namespace cmm::hal {

struct IppDmeSettings {
  std::string host = "127.0.0.1";
  int port = ippdme::kDefaultPort;
  // The I++ tool to use at connect (default: the description's active tip's); `tools` maps our tip
  // ids to the controller's tool names where they differ.
  std::string tool;
  std::map<std::string, std::string> tools;
  double connect_timeout_s = 2;     // "timeouts": {"connect_s", "response_s", "motion_s"}
  double response_timeout_s = 2;    // an acknowledgement, and a transaction that does not move
  // Home, GoTo and PtMeas wait as long as their path takes (motion_bound_s); motion_s, when set,
  // caps that bound: 0 is no cap.
  double motion_timeout_s = 0;
  double move_report_s = 0.1;       // OnMoveReportE's Time: at least 0.1 s (I++ DME 1.4.3 §6.3.2.7)
  int connect_attempts = 4;
  double connect_backoff_s = 0.05;  // doubled after each failed attempt
  std::string protocol_log;         // a file for every line with a time stamp; empty: none
  description::MachineDescription machine = description::default_machine();
};

// Relative file names in the block resolve against `base_dir`. Throws description::FieldError.
IppDmeSettings ippdme_settings_from_json(const nlohmann::json& block, const std::string& base_dir = ".");

class IppDmeCmm : public CmmDriver {
 public:
  explicit IppDmeCmm(std::string base_dir = ".");
  ~IppDmeCmm() override;

  std::optional<description::MachineDescription> configured_machine() const override;
  // What the server said it is at the last connect: "1.4.3", or "" when it does not know GetDMEVersion.
  std::string server_version() const;

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
  struct Link;  // the Asio socket; the threads that wait read it
  struct Transaction {
    ippdme::Tag tag;
    std::string line;
    bool acked = false, done = false;
    bool wake_on_ack = true;  // a query's sender waits for its end only: one wake-up, not two
    std::vector<std::vector<ippdme::Term>> data;
    std::vector<ippdme::ServerError> warnings;
    std::optional<ippdme::ServerError> error;
    // Ended unanswered by another transaction's severity ≥ 2 error (§6.2.5): "00012 (GoTo)".
    std::string ended_by;
  };
  using Items = std::vector<ippdme::Term>;
  struct Outcome {
    std::vector<Items> data;
    std::vector<ippdme::ServerError> warnings;
  };
  enum class Kind { query, motion, fast };

  // One transaction: sent once the previous command is acknowledged, waited for to its end. A
  // severity ≥ 2 error is cleared (ClearAllErrors) and thrown as its HAL fault; an e-stop is not
  // cleared (reset() does), a stop's abort is cleared by the stopping thread.
  // A motion waits up to bound_s (its motion_bound_s()); the others response_s.
  Outcome transact(Kind kind, const std::string& method, Items args, const char* what, double bound_s = 0);
  // `daemon`: OnMoveReportE, whose reports follow under its tag once it has ended.
  std::shared_ptr<Transaction> send(Kind kind, const std::string& method, const Items& args, const char* what,
                                    bool daemon = false);
  Outcome wait(const std::shared_ptr<Transaction>& tx, double timeout_s, const char* what, const std::string& method);
  [[noreturn]] void fail(const ippdme::ServerError& e, const char* what, const std::string& method);
  [[noreturn]] void fail_unanswered(const Transaction& tx, const char* what);
  bool server_homed(const char* what);
  void clear_errors(const char* what);
  void on_line(const std::string& line);
  void end_pending_locked(const ippdme::Reply& cause);  // with mutex_ held
  void start_move_reports();
  // Reads and hands out what has come, waiting up to max_wait for it; with io_mutex_ held.
  void pump(std::chrono::milliseconds max_wait);
  // Until ready() (checked under mutex_), the link goes down or out of step, or timeout_s: false then.
  bool await(const std::function<bool()>& ready, double timeout_s);
  void drain();  // reads what is there, if nobody else is reading
  void on_link_down();
  void link_out_of_step();
  void write_line(const std::string& line, const char* what);
  void close_link();
  void start_session();
  void set_prop(const std::string& name, double value, double& cache, const char* what);
  ippdme::Tag next_tag(bool event);
  Vec3 query_position(std::optional<double>* clock);
  // How long a motion may take: its path at the speed and acceleration it runs with, doubled, plus
  // response_s and kMotionSlackS; capped by motion_s when set.
  double motion_bound_s(double length_mm, double speed_mm_s) const;
  Vec3 last_position() const;  // the last report, Get or motion end (server frame)
  void go_to(const Vec3& target, const char* what);  // target in the server's frame
  double home_bound_s() const;
  // The ball centre of a PtMeas report, or a Protocol fault naming what is wrong with it.
  Vec3 reported_centre(const Items& items, const char* what) const;

  const description::StylusTip& active() const;
  std::string tool_of(const std::string& tip_id) const;
  // Our ball centre = the server's + (our recorded offset − the offset the server's tool has).
  Vec3 correction() const;
  Vec3 ours(const Vec3& server) const { return server + correction(); }
  Vec3 theirs(const Vec3& ball) const { return ball - correction(); }
  Vec3 theirs_inside(const Vec3& ball) const;  // a GoTo target, kept inside the travel box
  double host_clock() const;

  std::string base_dir_;
  IppDmeSettings settings_;
  std::vector<Vec3> server_offsets_;   // each tip's offset as configured: what the controller's tool has
  std::vector<double> server_radii_;   // each tip's radius as the server compensates with (ER)
  std::size_t active_ = 0;
  std::unique_ptr<ProtocolLog> log_;
  std::unique_ptr<Link> link_;
  std::string version_;
  bool has_clock_ = false;  // cmm-sim's Clock() extension

  std::mutex send_mutex_;   // one command between sending and its acknowledgement
  std::mutex query_mutex_;  // a Get is not queued behind a motion: see read_status
  std::mutex write_mutex_;
  std::mutex io_mutex_;  // the thread that reads the socket (one that waits for an answer)
  mutable std::mutex mutex_;  // what the reader thread hands over
  std::condition_variable wake_;
  std::map<std::string, std::shared_ptr<Transaction>> open_;  // by tag text
  bool link_down_ = false;
  std::string garbled_;  // a line that is not I++: the link is out of step
  std::optional<ippdme::Tag> report_tag_;
  Vec3 reported_ = Vec3::Zero();  // the move report's last position (server frame)
  std::optional<double> reported_clock_;
  bool estop_ = false, homed_ = false;
  std::string estop_text_;
  int next_number_ = 0, next_event_ = 0;

  std::atomic<bool> in_motion_{false};
  std::atomic<bool> stop_requested_{false}, abort_requested_{false};
  double probe_speed_ = -1, approach_ = -1, search_ = -1, retract_ = -1, goto_speed_ = -1;
};

}  // namespace cmm::hal
