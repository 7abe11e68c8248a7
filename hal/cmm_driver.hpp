// The driver base (spdlog's base_sink habit): it holds the lifecycle state and its checks, the
// connect attempts, and the fault and abort latches for every driver, and implements hal::Cmm with
// them; a driver writes its transport and protocol in the protected hooks, and nothing else.
#pragma once

#include <atomic>
#include <mutex>
#include <optional>
#include <string>

#include "hal/cmm.hpp"
#include "hal/fault.hpp"

namespace cmm::hal {

class CmmDriver : public Cmm {
 public:
  // configure: refused while connected; the hook parses the block. connect: from configured, up to
  // connect_policy().attempts tries with a doubling backoff, each running on_connect(); a try that
  // throws CommLost or Timeout is closed (on_disconnect) and retried, any other fault ends it. A link
  // made clears the fault the last one latched (not an abort).
  void configure(const nlohmann::json& block) final;
  void connect() final;
  void enable() final;
  void disable() final;
  void disconnect() final;

  std::optional<description::MachineDescription> configured_machine() const override { return std::nullopt; }
  description::MachineDescription info() final;
  // The driver's status with the lifecycle, and with the latched abort and fault when the machine
  // itself reports none.
  MachineStatus status() final;

  // Motion: enabled, no abort latched. A fault is latched (status() reports it until the next motion
  // succeeds, reset() or a new link) and drops an enabled machine back to connected.
  void home() final;
  void move(const Move& move) final;
  TouchResult probe(const ProbeMove& move) final;
  void stop() final;   // whatever the lifecycle: the driver reaches what it can
  void abort() final;  // latched here at once, and sent on by the driver
  void reset() final;  // connected; clears the latches once the machine has taken it

  void select_tip(const std::string& tip_id) final;
  void record_qualification(const std::string& tip_id, const description::TipQualification& q) final;

 protected:
  // `machine` names it in messages: "the Modbus machine".
  explicit CmmDriver(std::string machine);

  struct ConnectPolicy {
    int attempts = 1;
    double backoff_s = 0;  // before the second try; doubled before each one after
  };
  virtual ConnectPolicy connect_policy() const { return {}; }
  // Where the link goes, for "cannot reach <where> after 4 attempts": "the Modbus machine at host:port".
  virtual std::string where() const = 0;

  virtual void on_configure(const nlohmann::json& block) = 0;  // description::FieldError for a bad block
  virtual void on_connect() = 0;     // one try at the link; CommLost when it cannot be made, Timeout when unanswered
  virtual void on_enable() {}        // a check before motion is allowed
  virtual void on_disconnect() = 0;  // closes whatever is open; safe to call twice
  virtual description::MachineDescription read_info() = 0;
  virtual MachineStatus read_status() = 0;
  virtual void begin_motion() {}  // before each motion call, after the base's checks
  virtual void do_home() = 0;
  virtual void do_move(const Move& move) = 0;
  virtual TouchResult do_probe(const ProbeMove& move) = 0;
  virtual void do_stop() = 0;   // from any thread, in any lifecycle state
  virtual void do_abort() = 0;  // likewise
  virtual void do_reset() = 0;
  virtual void do_select_tip(const std::string& tip_id) = 0;
  virtual void do_record_qualification(const std::string& tip_id, const description::TipQualification& q) = 0;

  // The transport's word that the link went away or out of step (a request left unanswered may
  // still be answered): down to configured until connect(), which re-reads the machine.
  void drop_link();
  // The driver's own requests may use the link: connected, or inside on_connect() (where the rest of
  // the world still sees configured, so that nobody asks a half-made link for its status).
  bool link_up() const { return connecting_.load() || lifecycle_.load() >= Lifecycle::connected; }
  const std::string& machine_name() const { return machine_; }

 private:
  // Throws StateError ("move: the Modbus machine is connected, needs enabled") below `needed`.
  void require(Lifecycle needed, const char* what) const;
  void lower_to(Lifecycle state);  // an atomic step down, never up
  template <class F>
  auto motion(const char* what, F&& f);
  void latch(const Fault& fault);
  void clear_latches(bool abort_too);

  std::string machine_;
  std::atomic<Lifecycle> lifecycle_{Lifecycle::unconfigured};
  std::atomic<bool> connecting_{false};
  std::atomic<bool> aborted_{false};
  mutable std::mutex fault_mutex_;
  std::optional<FaultKind> fault_;
  std::string fault_message_;
};

}  // namespace cmm::hal
