// MachineLink's stop check: what lets machine.stop end a manual command between two of its motions.
#include <gtest/gtest.h>

#include "daemon/machine_link.hpp"
#include "hal/fault.hpp"

namespace cmm::daemon {
namespace {

TEST(MachineLinkStopCheck, PassesUntilAStopIsCountedAfterItWasMadeThenThrowsAborted) {
  MachineLink link(nullptr, nlohmann::json::object(), "none");  // the check never touches the driver
  link.count_stop();  // a stop before the command was asked for is not the command's
  const std::function<void()> check = link.stop_check();
  EXPECT_NO_THROW(check());
  link.count_stop();
  try {
    check();
    ADD_FAILURE() << "a stop counted after the check was made did not end it";
  } catch (const hal::Fault& f) {
    EXPECT_EQ(f.kind(), hal::FaultKind::aborted) << f.what();
  }
  EXPECT_THROW(check(), hal::Fault) << "the stop must keep ending the command, not only once";
  EXPECT_NO_THROW(link.stop_check()()) << "a check made after the stop is a new command's";
}

}  // namespace
}  // namespace cmm::daemon
