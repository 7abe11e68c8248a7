// Jogging: the operator moving the machine by hand (a dashboard button held, `cmmctl jog`) to find
// the plate's rough corners — short guarded segments inside the travel box, until released, stopped or touching.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "daemon/client/json_rpc.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/machine_link.hpp"
#include "hal/description/machine_description.hpp"
#include "hal/fault.hpp"

namespace cmm::daemon {

// One machine.jog call, checked. A step jog (distance_mm) runs to its end; a continuous one runs
// while its lease lasts: hold_s from its last call, which the client renews by calling again.
struct JogRequest {
  hal::Vec3 direction = hal::Vec3::UnitX();  // unit
  double speed_mm_s = 5;
  std::optional<double> distance_mm;
  double hold_s = 0.3;
};

// machine.jog's params; −32602 with every bad field by its pointer (a zero direction at /direction,
// a speed over the configured max_speed_mm_s at /speed_mm_s).
JogRequest jog_request_from_json(const nlohmann::json& params, const JogOptions& options);

// How far the ball may go from `from` along `direction` (unit) and stay inside `box` shrunk by
// `margin_mm` on the faces it moves toward (an axis it moves away from, or not at all, never
// limits it, so a ball homed to the box's corner can still jog back in), and the face that limits
// it: "+x", "-z", ….
struct JogReach {
  double mm = 0;
  std::string face;
};
JogReach jog_reach(const description::TravelBox& box, double margin_mm, const hal::Vec3& from, const hal::Vec3& direction);

// How a jog ended, for machine.status's last_jog and the log.
struct JogEnd {
  int id = 0;
  std::string reason;  // "travelled 5 mm", "released", "at the travel box's +x face", "stopped by …", a fault's message
  std::optional<hal::FaultKind> fault;  // EarlyTrigger: the probe touched something; Aborted: a stop
};

class MachineJog {
 public:
  MachineJog(MachineLink& machine, JogOptions options, description::TravelBox configured_box);
  ~MachineJog();  // stops a jog in progress and waits for it (one segment at most)
  MachineJog(const MachineJog&) = delete;
  MachineJog& operator=(const MachineJog&) = delete;

  struct Started {
    int id = 0;
    hal::Vec3 position = hal::Vec3::Zero();  // where the ball was when the call came
    bool renewed = false;                    // the running jog's lease was extended
  };
  // Starts a jog for `client` (RpcContext::client), or renews the running one (a continuous jog of the
  // same client in the same direction: its lease is extended and its speed taken), or replaces it
  // (anything else from that client: the new jog starts where the running one's current segment
  // ends). A jog belongs to the client that started it: another client's call is refused, so a
  // second dashboard can never keep a jog alive that its owner let go. Returns at once; the jog runs
  // on a thread of its own, holding the machine's lease. Throws RpcError: machine_busy while a job,
  // a command or another client's jog holds the machine; machine_fault (NotHomed, SoftLimit naming the face it is at, EarlyTrigger while the
  // probe still touches what the last jog met along this direction, a link fault); invalid_state
  // while a touch a stop cut short is recorded.
  Started jog(const JogRequest& request, const std::string& client);
  // Ends the running jog at once, whoever started it: the machine's controlled stop (the segment in progress throws
  // Aborted, which machine.status shows as the last fault). A jog that is not running is left as it is.
  void stop();

  // null | {"id", "direction", "speed_mm_s", "distance_mm": null | mm}: the jog running now.
  nlohmann::json status_json() const;
  // null | {"id", "reason", "fault": null | kind}: how the last jog ended.
  nlohmann::json last_json() const;
  std::optional<JogEnd> last_end() const;
  bool running() const;
  const JogOptions& options() const { return options_; }

 private:
  struct Command {
    int id = 0;
    std::string client;  // who started it, and alone may renew or replace it
    JogRequest request;
    std::chrono::steady_clock::time_point deadline;  // a continuous jog's lease
  };
  struct Limits {
    description::TravelBox box;  // the configured box cut down to the one the machine reports
    double margin_mm = 0;        // the active tip's ball radius
  };
  void run(std::optional<MachineLink::Lease> lease, std::function<void()> check_stop);
  hal::MachineStatus read_status();  // faults as RpcError
  Command command_for(const JogRequest& request, const std::string& client);
  void refuse_if_blocked(const hal::MachineStatus& status, const JogRequest& request) const;

  MachineLink& machine_;
  JogOptions options_;
  description::TravelBox configured_box_;
  std::mutex start_mutex_;  // one jog() at a time: a start, renewal or replacement is decided whole
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::thread thread_;
  bool running_ = false;
  bool stop_ = false;
  Command command_;
  Limits limits_;
  int next_id_ = 1;
  std::optional<JogEnd> last_;
  struct Contact {
    hal::Vec3 direction;  // of the jog that met it
    hal::Vec3 position;   // where the ball stopped at it
  };
  std::optional<Contact> contact_;
};

// machine.jog (operator, blocking: the first call reads the machine) and machine.jog_stop (observer:
// a stop is always safe; quick: it must never wait behind a slow method).
void add_jog_methods(RpcDispatcher& dispatcher, const std::shared_ptr<MachineJog>& jog);

}  // namespace cmm::daemon
