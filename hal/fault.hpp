// The HAL's one typed fault family (DESIGN.md): every driver turns what went wrong on the machine or
// its link into one of these, so a job runner can pause on a CommLost and stop on an EStop alike.
#pragma once

#include <stdexcept>
#include <string>

namespace cmm::hal {

enum class FaultKind {
  comm_lost,      // the link dropped or never came up
  timeout,        // the machine did not answer, or did not finish, in time
  protocol,       // an answer the driver cannot parse or that contradicts the protocol
  not_homed,      // motion asked before homing (or after something lost the position)
  soft_limit,     // a target outside the travel box; refused before moving
  hard_limit,     // the machine hit a limit switch
  early_trigger,  // the probe triggered where no touch may be: a guarded move, or before min travel
  no_contact,     // a search ran its whole travel without a trigger (fail_on_miss)
  estop,          // the machine's own emergency-stop input
  aborted,        // abort() was called; latched until reset()
};

const char* to_string(FaultKind kind);  // "CommLost", "Timeout", … as DESIGN.md spells them
// The kind named by to_string, for wire formats and config; throws std::invalid_argument otherwise.
FaultKind fault_kind_from_string(const std::string& name);

class Fault : public std::runtime_error {
 public:
  Fault(FaultKind kind, const std::string& message);
  FaultKind kind() const { return kind_; }

 private:
  FaultKind kind_;
};

// One class per kind, so callers can catch exactly the faults they handle.
template <FaultKind K>
class FaultOf : public Fault {
 public:
  explicit FaultOf(const std::string& message) : Fault(K, message) {}
};
using CommLost = FaultOf<FaultKind::comm_lost>;
using Timeout = FaultOf<FaultKind::timeout>;
using Protocol = FaultOf<FaultKind::protocol>;
using NotHomed = FaultOf<FaultKind::not_homed>;
using SoftLimit = FaultOf<FaultKind::soft_limit>;
using HardLimit = FaultOf<FaultKind::hard_limit>;
using EarlyTrigger = FaultOf<FaultKind::early_trigger>;
using NoContact = FaultOf<FaultKind::no_contact>;
using EStop = FaultOf<FaultKind::estop>;
using Aborted = FaultOf<FaultKind::aborted>;

// Throws the typed fault of `kind`: how a driver re-raises a fault that arrived as a code on the wire.
[[noreturn]] void throw_fault(FaultKind kind, const std::string& message);

// Calling a method in the wrong lifecycle state (moving before enable()) is the caller's bug, not a
// machine fault, so it is a logic_error and does not change the state.
class StateError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

}  // namespace cmm::hal
