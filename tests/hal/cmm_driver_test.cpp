// The driver base's shared behaviour, on a scripted driver (a unit test's stand-in for a transport):
// which connect faults are retried, what a new link clears, what the lifecycle refuses.
#include "hal/cmm_driver.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <deque>
#include <functional>

#include "hal/description/machine_description.hpp"

namespace cmm::hal {
namespace {

using ::testing::HasSubstr;

// Each connect try runs the next scripted step (none left: the link is made); a move runs `on_move`.
class ScriptedDriver : public CmmDriver {
 public:
  ScriptedDriver() : CmmDriver("the scripted machine") {}
  std::deque<std::function<void()>> connect_steps;
  std::function<void()> on_move;
  int tries = 0, closes = 0;
  void lose_link() { drop_link(); }

 protected:
  ConnectPolicy connect_policy() const override { return {3, 0}; }
  std::string where() const override { return "the scripted machine"; }
  void on_configure(const nlohmann::json&) override {}
  void on_connect() override {
    ++tries;
    if (connect_steps.empty()) return;
    const std::function<void()> step = connect_steps.front();
    connect_steps.pop_front();
    step();
  }
  void on_disconnect() override { ++closes; }
  description::MachineDescription read_info() override { return description::default_machine(); }
  MachineStatus read_status() override { return {}; }
  void do_home() override {}
  void do_move(const Move&) override {
    if (on_move) on_move();
  }
  TouchResult do_probe(const ProbeMove&) override { return {}; }
  void do_stop() override {}
  void do_abort() override {}
  void do_reset() override {}
  void do_select_tip(const std::string&) override {}
  void do_record_qualification(const std::string&, const description::TipQualification&) override {}
};

TEST(CmmDriver, ConnectRetriesALinkNotThereYetAndAMachineNotAnsweringYet) {
  ScriptedDriver d;
  d.configure({});
  d.connect_steps = {[] { throw CommLost("refused"); }, [] { throw Timeout("no banner yet"); }};
  d.connect();
  EXPECT_EQ(d.tries, 3);
  EXPECT_EQ(d.closes, 2) << "each failed try is closed";
  EXPECT_EQ(d.status().lifecycle, Lifecycle::connected);
}

TEST(CmmDriver, ConnectGivesUpAfterItsAttemptsWithTheLastReason) {
  ScriptedDriver d;
  d.configure({});
  for (int i = 0; i < 3; ++i) d.connect_steps.push_back([] { throw Timeout("no banner"); });
  try {
    d.connect();
    FAIL() << "connected";
  } catch (const CommLost& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot reach the scripted machine after 3 attempts: Timeout: no banner"));
  }
  EXPECT_EQ(d.tries, 3);
}

// A garbled answer (wrong device or baud), another register map's version, the e-stop: trying again
// would only say it again, later.
TEST(CmmDriver, ConnectEndsAtOnceOnAFaultThatATryAgainCannotMend) {
  ScriptedDriver d;
  d.configure({});
  d.connect_steps = {[] { throw Protocol("register map version 7"); }};
  EXPECT_THROW(d.connect(), Protocol);
  EXPECT_EQ(d.tries, 1);
  EXPECT_EQ(d.closes, 1);
  EXPECT_THROW(d.status(), StateError) << "not connected";
}

TEST(CmmDriver, ANewLinkClearsTheLatchedFaultButNotTheAbort) {
  ScriptedDriver d;
  d.configure({});
  d.connect();
  d.enable();
  d.on_move = [&] { throw CommLost("the link dropped"); };
  EXPECT_THROW(d.move({Vec3::Zero(), 10}), CommLost);
  EXPECT_EQ(d.status().fault, FaultKind::comm_lost);
  d.lose_link();
  d.connect();
  EXPECT_FALSE(d.status().fault) << "what the old link reported is history";

  d.abort();
  d.lose_link();
  d.connect();
  EXPECT_TRUE(d.status().aborted) << "an abort waits for reset()";
  d.enable();
  EXPECT_THROW(d.move({Vec3::Zero(), 10}), Aborted);
  d.reset();
  d.enable();
  d.on_move = nullptr;
  EXPECT_NO_THROW(d.move({Vec3::Zero(), 10}));
}

TEST(CmmDriver, TheLifecycleRefusesCallsOutOfOrder) {
  ScriptedDriver d;
  EXPECT_THROW(d.connect(), StateError);
  d.configure({});
  d.connect();
  EXPECT_THROW(d.move({Vec3::Zero(), 10}), StateError) << "not enabled";
  EXPECT_THROW(d.configure({}), StateError) << "connected";
}

}  // namespace
}  // namespace cmm::hal
