// cmmd's one machine: the driver behind hal::Cmm, brought up (configure → connect → enable) and
// brought back after a link fault, and leased to one user at a time (a job or a manual command).
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "hal/cmm.hpp"

namespace cmm::daemon {

class MachineLink {
 public:
  MachineLink(std::unique_ptr<hal::Cmm> cmm, nlohmann::json block, std::string driver);

  // Configures once, then connects and enables as far as needed. Throws hal::Fault (CommLost when
  // the machine cannot be reached) or hal::ConfigError for a bad driver block.
  void bring_up();
  // status() that never throws: a link that is down reads as {"link": "down", "fault": …}.
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
  std::optional<std::string> holder() const;

 private:
  std::unique_ptr<hal::Cmm> cmm_;
  nlohmann::json block_;
  std::string driver_;
  bool configured_ = false;
  std::mutex bring_up_mutex_;
  mutable std::mutex lease_mutex_;
  std::optional<std::string> holder_;
};

nlohmann::json fault_json(const std::exception& e);  // {"kind", "message"}; kind "Internal" for a non-fault

}  // namespace cmm::daemon
