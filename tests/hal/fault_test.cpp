// The fault family: names as DESIGN.md spells them, and a wire code re-raised as its own type.
#include "hal/fault.hpp"

#include <gtest/gtest.h>

namespace cmm::hal {
namespace {

TEST(Fault, NamesRoundTrip) {
  for (auto kind : {FaultKind::comm_lost, FaultKind::timeout, FaultKind::protocol, FaultKind::not_homed,
                    FaultKind::soft_limit, FaultKind::hard_limit, FaultKind::early_trigger, FaultKind::no_contact,
                    FaultKind::estop, FaultKind::aborted})
    EXPECT_EQ(fault_kind_from_string(to_string(kind)), kind);
  EXPECT_STREQ(to_string(FaultKind::early_trigger), "EarlyTrigger");
  EXPECT_THROW(fault_kind_from_string("Oops"), std::invalid_argument);
}

TEST(Fault, ThrowFaultRaisesTheTypedClass) {
  EXPECT_THROW(throw_fault(FaultKind::no_contact, "x"), NoContact);
  EXPECT_THROW(throw_fault(FaultKind::estop, "x"), EStop);
  try {
    throw_fault(FaultKind::comm_lost, "link down");
  } catch (const Fault& f) {
    EXPECT_EQ(f.kind(), FaultKind::comm_lost);
    EXPECT_STREQ(f.what(), "CommLost: link down");
  }
}

}  // namespace
}  // namespace cmm::hal
