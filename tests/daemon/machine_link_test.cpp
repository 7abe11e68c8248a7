// MachineLink's stop check (what lets machine.stop end a manual command between two of its motions)
// and its status while the link is down: why, and an e-stop nobody can read.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>

#include "daemon/machine_link.hpp"
#include "hal/cmm_driver.hpp"
#include "hal/fault.hpp"
#include "hal/utc_time.hpp"

namespace cmm::daemon {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

// A driver on the real base whose machine refuses each connect try with `refusal` while it is set,
// and once reached reports its e-stop pressed (so a status that read it cannot pass for one that did not).
class DoorDriver : public hal::CmmDriver {
 public:
  DoorDriver() : CmmDriver("the door machine") {}
  std::function<void()> refusal;

 protected:
  ConnectPolicy connect_policy() const override { return {2, 0}; }
  std::string where() const override { return "the door machine at 127.0.0.1:9"; }
  void on_configure(const json&) override {}
  void on_connect() override {
    if (refusal) refusal();
  }
  void on_disconnect() override {}
  description::MachineDescription read_info() override { return description::default_machine(); }
  hal::MachineStatus read_status() override {
    hal::MachineStatus s;
    s.estop = true;
    return s;
  }
  void do_home() override {}
  void do_move(const hal::Move&) override {}
  hal::TouchResult do_probe(const hal::ProbeMove&) override { return {}; }
  void do_stop() override {}
  void do_abort() override {}
  void do_reset() override {}
  void do_select_tip(const std::string&) override {}
  void do_record_qualification(const std::string&, const description::TipQualification&) override {}
};

TEST(MachineLinkStatus, WhileTheLinkIsDownSaysWhyTheLastConnectFailedAndTheEStopIsUnknown) {
  auto owned = std::make_unique<DoorDriver>();
  DoorDriver& driver = *owned;
  MachineLink link(std::move(owned), json::object(), "door");

  const json before = link.status_json();
  EXPECT_EQ(before["link"], "down") << before;
  EXPECT_EQ(before["lifecycle"], "unconfigured") << before;
  EXPECT_TRUE(before["estop"].is_null()) << before;
  EXPECT_TRUE(before["fault"].is_null()) << "no connect tried yet, so no reason: " << before;
  EXPECT_TRUE(before["connect_error"].is_null()) << before;

  driver.refusal = [] { throw hal::CommLost("connection refused"); };
  EXPECT_THROW(link.bring_up(), hal::CommLost);
  const json down = link.status_json();
  EXPECT_EQ(down["link"], "down") << down;
  EXPECT_EQ(down["lifecycle"], "configured") << down;
  EXPECT_TRUE(down.contains("estop") && down["estop"].is_null()) << "a released e-stop must not be shown: " << down;
  ASSERT_TRUE(down["connect_error"].is_object()) << down;
  EXPECT_EQ(down["connect_error"]["kind"], "CommLost") << down;
  EXPECT_THAT(down["connect_error"]["message"].get<std::string>(),
              HasSubstr("cannot reach the door machine at 127.0.0.1:9 after 2 attempts: CommLost: connection refused"));
  EXPECT_NO_THROW(hal::unix_seconds(down["connect_error"]["utc"].get<std::string>())) << down;
  EXPECT_EQ(down["fault"], (json{{"kind", "CommLost"}, {"message", down["connect_error"]["message"]}}))
      << "the fault is why the link is down, not a refusal to read the status: " << down;
}

// A connect that ends at once on its own kind (a controller without the configured tool) says so,
// not CommLost; a link made clears it.
TEST(MachineLinkStatus, AConnectErrorKeepsItsKindAndALinkMadeClearsIt) {
  auto owned = std::make_unique<DoorDriver>();
  DoorDriver& driver = *owned;
  MachineLink link(std::move(owned), json::object(), "door");
  driver.refusal = [] { throw hal::Protocol("the controller has no tool \"T1\""); };
  EXPECT_THROW(link.bring_up(), hal::Protocol);
  const json refused = link.status_json();
  ASSERT_TRUE(refused["connect_error"].is_object()) << refused;
  EXPECT_EQ(refused["connect_error"]["kind"], "Protocol") << refused;
  EXPECT_THAT(refused["connect_error"]["message"].get<std::string>(), HasSubstr("no tool \"T1\""));
  EXPECT_EQ(refused["fault"]["kind"], "Protocol") << refused;

  driver.refusal = nullptr;
  link.bring_up();
  const json up = link.status_json();
  EXPECT_EQ(up["link"], "up") << up;
  EXPECT_TRUE(up["connect_error"].is_null()) << up;
  EXPECT_TRUE(up["fault"].is_null()) << up;
  EXPECT_EQ(up["estop"], true) << "read from the machine once the link is up: " << up;
}

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
