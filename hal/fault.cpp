// Fault names as DESIGN.md spells them, and the typed throw behind wire codes.
#include "hal/fault.hpp"

#include <array>
#include <utility>

namespace cmm::hal {

namespace {
constexpr std::array<std::pair<FaultKind, const char*>, 10> kNames{{
    {FaultKind::comm_lost, "CommLost"},
    {FaultKind::timeout, "Timeout"},
    {FaultKind::protocol, "Protocol"},
    {FaultKind::not_homed, "NotHomed"},
    {FaultKind::soft_limit, "SoftLimit"},
    {FaultKind::hard_limit, "HardLimit"},
    {FaultKind::early_trigger, "EarlyTrigger"},
    {FaultKind::no_contact, "NoContact"},
    {FaultKind::estop, "EStop"},
    {FaultKind::aborted, "Aborted"},
}};
}  // namespace

const char* to_string(FaultKind kind) {
  for (const auto& [k, name] : kNames)
    if (k == kind) return name;
  return "Unknown";
}

FaultKind fault_kind_from_string(const std::string& name) {
  for (const auto& [k, n] : kNames)
    if (name == n) return k;
  throw std::invalid_argument("unknown fault kind \"" + name + "\"");
}

Fault::Fault(FaultKind kind, const std::string& message)
    : std::runtime_error(std::string(to_string(kind)) + ": " + message), kind_(kind) {}

void throw_fault(FaultKind kind, const std::string& message) {
  switch (kind) {
    case FaultKind::comm_lost: throw CommLost(message);
    case FaultKind::timeout: throw Timeout(message);
    case FaultKind::protocol: throw Protocol(message);
    case FaultKind::not_homed: throw NotHomed(message);
    case FaultKind::soft_limit: throw SoftLimit(message);
    case FaultKind::hard_limit: throw HardLimit(message);
    case FaultKind::early_trigger: throw EarlyTrigger(message);
    case FaultKind::no_contact: throw NoContact(message);
    case FaultKind::estop: throw EStop(message);
    case FaultKind::aborted: throw Aborted(message);
  }
  throw Protocol("fault code out of range: " + message);
}

}  // namespace cmm::hal
