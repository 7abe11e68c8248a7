// cmm-sim's I++ DME side (`cmm-sim --ippdme PORT`): serves one SimulatedMachine as an I++ DME
// server over TCP, in the line grammar of hal/ippdme_protocol.hpp, with the link faults of the
// config (drop, delay, corrupt) injected on the wire.
//
// It follows I++ DME 1.4.3 (§ numbers below) and enforces what NIST's test-suite server does. The
// contract the client driver (hal/ippdme_cmm.hpp) relies on, in brief (docs/ippdme.md):
// - One session at a time: a second connection is accepted and closed at once. A disconnect drops
//   everything pending (a running motion is stopped with machine.stop()); the machine keeps its
//   state, and the next client starts with StartSession.
// - Lines end CRLF (a bare LF too). A line over kMaxLineChars is answered once with 0000, then
//   discarded up to its LF; a half line is never executed; an empty line is ignored.
// - Every error carries §8.2's number, text and default severity (0000 raised to 2). Every
//   transaction ends with `%`, an errored one too (§6.2.3's example).
// - Refused before acceptance, no `&`, on the line's tag and then its `%` (E0000 and no `%` if the
//   tag is unreadable; no `%` for the tag of an open transaction, which would end that one): parse
//   errors (0000/0001/0002/0007/0008), unknown commands (0501), the wrong queue's tag (0001), the
//   tag of an open transaction (0001), anything but StartSession before it (0008), a second
//   StartSession (0008, §6.3.1).
// - Accepted: `TAG &` at once. E-tag commands (AbortE, GetErrStatusE, GetPropE, OnMoveReportE,
//   StopDaemon, StopAllDaemons) run at once on the receiving thread; the others run one at a time in
//   order. In the error state a normal command other than ClearAllErrors is answered `&`, 0514, `%`
//   (§6.3.1.7's example).
// - Any error of severity ≥ 2, and AbortE, enter the error state (§6.2.5) until ClearAllErrors (or
//   StartSession) is accepted. The queued transactions are aborted: each answered 0006 and `%`
//   (§6.3.1.5), or, with PendingOnError::drop, never answered at all, as NIST's server does. An
//   e-stop first sends the event `E0000 ! Error(3, 0500, Method, "Emergency stop")`.
// - Motion before Home is 0507, an unknown tool 1502, a target outside the volume 1008.
// - OnMoveReportE (§6.3.2.7) needs Time ≥ 0.1 and Dis > 0 (0510 otherwise) and no daemon running
//   (0515); it is answered `&` `%` at once, and its reports follow under its tag: X, Y, Z (and
//   cmm-sim's Clock()) while a motion runs, at most 10 a second, and once more as a motion command
//   ends, before that command's last line. StopDaemon of a tag without one is 0513; StopAllDaemons
//   with none is warning 0512.
// - Link faults count Home, GoTo, PtMeas and ClearAllErrors as they are accepted:
//   drop_link_after_commands closes the connection instead of acknowledging the next one (once);
//   reply_delay_s delays every line of a counted command (acks included); corrupt_reply_at_command
//   garbles that command's final line.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "hal/ippdme_protocol.hpp"
#include "hal/protocol_log.hpp"
#include "sim/simulated_machine.hpp"

namespace cmm::sim {

struct IppDmeEndpoint {
  std::string host = "127.0.0.1";
  int port = 0;  // 0: any free port
};

// What becomes of the transactions queued when a severity ≥ 2 error comes (§6.2.5): `answer` each
// with 0006 and `%` as §6.3.1.5 does for AbortE, or `drop` them without a word as NIST's I++ DME
// test-suite server does (cmm-sim --ippdme-pending-on-error).
enum class PendingOnError { answer, drop };
struct IppDmeOptions {
  PendingOnError pending_on_error = PendingOnError::answer;
};

class IppDmeServer {
 public:
  // Listens at once; port() tells a port chosen by the system. `log`, when given, gets every line
  // received and sent and a note for each connect, disconnect and dropped line; it must outlive
  // the server. Throws std::runtime_error naming the address when it cannot listen.
  IppDmeServer(SimulatedMachine& machine, const FaultInjection& faults, const IppDmeEndpoint& endpoint,
               hal::ProtocolLog* log = nullptr, IppDmeOptions options = {});
  ~IppDmeServer();
  IppDmeServer(const IppDmeServer&) = delete;
  IppDmeServer& operator=(const IppDmeServer&) = delete;

  int port() const { return port_; }
  void serve();     // the accept and receive loop, until shutdown(); from one thread
  void shutdown();  // from any thread

 private:
  struct Link;  // the Asio acceptor and the client's socket (kept out of this header)

  struct Transaction {
    hal::ippdme::Tag tag;
    std::string method;
    std::vector<hal::ippdme::Term> args;
    int command = 0;              // its number among the counted commands (link faults); 0: not counted
    std::uint64_t connection = 0;
    bool ended = false;           // already answered (AbortE, a disconnect): the worker's answer is dropped
  };
  // OnMoveReportE's daemon.
  struct Daemon {
    hal::ippdme::Tag tag;
    std::uint64_t id = 0;
    std::optional<double> every_s, beyond_mm;  // Time(s), Dis(d)
    std::vector<std::string> axes;             // "X", "Y", "Z" in the order asked
  };

  struct Delayed {
    std::chrono::steady_clock::time_point due;
    std::string line;
    std::uint64_t connection = 0;
  };

  // The receiving thread.
  void accept_client();
  void end_connection(const std::string& why);
  void receive(std::string_view bytes);
  void take_line(std::string_view line);
  void line_too_long(std::string_view head);
  void run_fast_locked(const hal::ippdme::Command& command);
  void start_daemon_locked(const hal::ippdme::Command& command);  // OnMoveReportE
  void stop_daemon_locked(const hal::ippdme::Command& command);   // StopDaemon, StopAllDaemons

  // The worker and what it runs.
  void worker_loop();
  void execute(const Transaction& tx);
  void run_normal(const Transaction& tx);
  void go_to(const std::vector<hal::ippdme::Term>& args);
  void set_properties(const std::vector<hal::ippdme::Term>& args);
  void pt_meas(const std::vector<hal::ippdme::Term>& args);
  void clear_machine_errors();

  // The move-report daemon's thread, and the reply delay's.
  void report_loop();
  void outbox_loop();

  // Properties (Tool.PtMeasPar.*, Tool.GoToPar.*) and report formats; with mutex_ held.
  void reset_session_settings_locked();
  std::vector<hal::ippdme::Term> read_properties_locked(const std::vector<hal::ippdme::Term>& args) const;

  // Lines out. The *_locked ones with mutex_ held; reply_* answer the worker's current transaction
  // (nothing once it has ended); end_locked writes a transaction's final line.
  // `delayed`: a line of a counted command, which reply_delay_s holds back.
  void send_locked(const hal::ippdme::Reply& reply, bool delayed = false);
  void report_end_of_motion_locked();  // the daemon's report as a motion command ends
  void error_locked(hal::ippdme::Tag tag, int severity, int code, const std::string& method, const std::string& text);
  // A line not accepted: its error, its `%` when `complete`, and the error state.
  void refuse_locked(hal::ippdme::Tag tag, const std::string& method, int code, const std::string& text,
                     bool complete = true);
  void end_locked(Transaction& tx, hal::ippdme::Reply reply);
  // tx's error (§8.2's severity) and its `%`; the error state when the severity is ≥ 2.
  void fail_locked(Transaction& tx, int code, const std::string& text);
  // `aborting`: AbortE's, whose pending ones are always answered (§6.3.1.5).
  void enter_error_state_locked(bool aborting = false);
  void abort_locked(Transaction& tx);  // 0006 and `%`
  bool tag_open_locked(hal::ippdme::Tag tag) const;
  void reply_data(std::vector<hal::ippdme::Term> data);
  void reply_warning(int code, const std::string& text);
  void reply_done();
  void reply_error(int code, const std::string& text);
  void send_line_locked(std::string line, bool delayed);
  void write_line(const std::string& line, std::uint64_t connection);
  void note(const std::string& text);

  SimulatedMachine& machine_;
  FaultInjection faults_;
  hal::ProtocolLog* log_;
  IppDmeOptions options_;
  description::MachineDescription description_;  // at start: the limits SetProp clamps to
  std::unique_ptr<Link> link_;
  int port_ = 0;
  std::atomic<bool> running_{true};

  // The receiving thread's own.
  std::string partial_;     // the line being received
  bool discarding_ = false; // the rest of an over-long line, up to its LF
  bool drop_now_ = false;   // drop_link_after_commands fired on the line just taken

  // Shared, under mutex_ (lock order: mutex_, then write_mutex_).
  std::mutex mutex_;
  std::condition_variable work_wake_, report_wake_, outbox_wake_;
  std::uint64_t connection_ = 0;  // bumped at every connect and disconnect; changed under both mutexes
  bool session_open_ = false;     // as acceptance sees it: StartSession/EndSession count when accepted
  bool error_state_ = false;      // after a severity ≥ 2 error or AbortE, until ClearAllErrors
  std::deque<Transaction> queue_;
  std::optional<Transaction> current_;  // the one the worker runs
  std::optional<Daemon> daemon_;
  std::uint64_t daemons_ = 0;
  bool end_reported_ = false;  // the worker reported a motion's end: the daemon thread need not
  std::map<std::string, double, std::less<>> properties_;
  std::vector<std::string> pt_report_;  // OnPtMeasReport's items, in order
  int commands_ = 0;
  bool dropped_ = false;
  std::deque<Delayed> outbox_;

  std::mutex write_mutex_;  // every write to the socket, one line at a time
  std::thread worker_, reporter_, outbox_thread_;
};

}  // namespace cmm::sim
