// cmmd's one machine: the driver behind hal::Cmm, brought up (configure → connect → enable) and
// brought back after a link fault, and leased to one user at a time (a job or a manual command).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "hal/cmm.hpp"
#include "hal/qualification.hpp"

namespace cmm::daemon {

// The search line of a touch the ball may still be on (it entered and has not yet come back to the
// start): whoever moves next leaves along it instead of rising straight from where the ball stopped.
struct SearchLine {
  hal::Vec3 start = hal::Vec3::Zero();
  hal::Vec3 direction = -hal::Vec3::UnitZ();
};

class MachineLink {
 public:
  // `touch_file` keeps the touch in progress across a restart of cmmd (empty: memory only).
  MachineLink(std::unique_ptr<hal::Cmm> cmm, nlohmann::json block, std::string driver,
              std::filesystem::path touch_file = {});

  // Configures once, then connects and enables as far as needed. Throws hal::Fault (CommLost when
  // the machine cannot be reached) or description::FieldError for a bad driver block; what it threw
  // before the link was made is kept as connect_error().
  void bring_up();
  // Why the last bring_up() could not make the link: {"kind", "message", "utc"} as fault_json names
  // the error, with the time it failed. Null before the first try and once a link has been made:
  // whoever asks for the status while the link is down learns why without reading the log.
  nlohmann::json connect_error() const;
  // How many times bring_up() found the link down and brought it up: a job compares it to see that
  // the driver reconnected (a controller that restarted may have lost its tip qualifications).
  std::uint64_t connections() const { return connections_.load(); }

  // hal::qualify on the machine (the lease holder's motion), and the result remembered as the
  // machine then reports it: a job held because its tip's qualification changed takes on exactly a
  // qualification cmmd itself measured (machine.qualify, or the job's own requalification).
  description::TipQualification qualify(const std::string& tip_id, const hal::QualificationOptions& options);
  // The tip as the machine reported it right after cmmd last qualified it (since cmmd started).
  std::optional<description::StylusTip> qualified_by_cmmd(const std::string& tip_id) const;
  // Each tip as the machine reports it: id, active, radius, offset, and its qualification (null: never
  // qualified, or forgotten by a controller that restarted). Empty when the link is down.
  nlohmann::json tips_json();
  // status() that never throws (machine.status in docs/api.md): a link that is down reads as
  // {"link": "down", "estop": null, "fault": the connect error, "connect_error": …}.
  nlohmann::json status_json();
  hal::Cmm& cmm() { return *cmm_; }  // motion for the lease holder; status, stop, abort for anyone
  const std::string& driver() const { return driver_; }

  // Exclusive use of the machine for motion. A job holds it for its whole run; machine.home and
  // machine.qualify hold it for one call, so they cannot move the machine under a job.
  class Lease {
   public:
    explicit Lease(MachineLink& link) : link_(&link) {}
    Lease(Lease&& other) noexcept : link_(other.link_) { other.link_ = nullptr; }
    Lease& operator=(Lease&&) = delete;
    ~Lease();

   private:
    MachineLink* link_;
  };
  // Empty when someone else holds the machine; holder() then says who.
  std::optional<Lease> try_lease(const std::string& holder);
  // As try_lease, but waits up to `patience` while only the monitor's reconnect attempt (holder
  // kReconnectHolder, a few seconds at most) holds the machine: a command issued just as cmmd
  // starts, or as a cable comes back, must not fail for that. A job or a command still refuses at once.
  std::optional<Lease> lease_after_reconnect(const std::string& holder, std::chrono::milliseconds patience);
  static constexpr const char* kReconnectHolder = "reconnect";
  std::optional<std::string> holder() const;

  // Recorded (durably, with a touch file) before a touch's first motion, cleared once the ball is
  // back at its start. When the touch file cannot be written (a full disk: geometry::FileError),
  // nothing is recorded and the touch must not begin.
  void enter_touch(const SearchLine& line);
  void left_touch();
  std::optional<SearchLine> touch_in_progress() const;

  // machine.stop, machine.abort and shutdown are counted: a manual command of several motions
  // checks before and after each that no stop came since it began, since a stop reaches only a
  // motion that is running. stop_check() is that check: it throws hal::Fault(Aborted) once a stop
  // has been counted after it was made.
  void count_stop() { ++stops_; }
  std::function<void()> stop_check() const;

 private:
  std::unique_ptr<hal::Cmm> cmm_;
  nlohmann::json block_;
  std::string driver_;
  std::atomic<bool> configured_{false};  // read by status_json while bring_up holds its mutex
  std::mutex bring_up_mutex_;
  mutable std::mutex connect_error_mutex_;  // not bring_up_mutex_: a connect may try for seconds
  nlohmann::json connect_error_;
  mutable std::mutex lease_mutex_;
  std::optional<std::string> holder_;
  std::condition_variable released_;
  std::filesystem::path touch_file_;
  mutable std::mutex touch_mutex_;
  std::optional<SearchLine> touch_;
  std::atomic<std::uint64_t> stops_{0};
  std::atomic<std::uint64_t> connections_{0};
  mutable std::mutex qualified_mutex_;
  std::map<std::string, description::StylusTip> qualified_;
};

nlohmann::json fault_json(const std::exception& e);  // {"kind", "message"}; kind "Internal" for a non-fault

}  // namespace cmm::daemon
