// cmmd under a stand-in for systemd: a datagram socket as NOTIFY_SOCKET receives READY=1 with a
// STATUS, STATUS lines that follow the machine link (cmm-sim over Modbus, then gone), watchdog kicks
// and STOPPING=1 on SIGTERM.
#include <gtest/gtest.h>
#include <signal.h>

#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "notify_listener.hpp"
#include "tests/daemon/fresh_folder.hpp"

namespace cmm {
namespace {

using nlohmann::json;

TEST(CmmdNotify, ReadyStatusOfTheLinkWatchdogKicksAndStopping) {
  const auto dir = daemon::fresh_folder("notify");
  {
    std::ofstream(dir / "sim.json") << testing::sample_sim_block().dump();
  }
  auto sim = std::make_unique<testing::SimulatorProcess>(dir / "sim.json", 1000);
  json machine = testing::modbus_block(sim->port);
  machine["connect_attempts"] = 1;
  machine["response_timeout_s"] = 0.3;
  testing::CmmdInstance cmmd(dir / "cmmd", machine);
  testing::NotifyListener manager(dir / "notify.sock");
  cmmd.start(testing::notify_launcher(manager, 400'000));  // WatchdogSec=0.4: a kick every 0.2 s

  const std::string ready = manager.wait_for("READY=1", 60);
  EXPECT_NE(ready.find("\nSTATUS=ready; machine driver modbus"), std::string::npos) << ready;
  const std::string up = manager.wait_for("STATUS=machine up", 60);
  EXPECT_NE(up.find("idle"), std::string::npos) << up;
  manager.wait_for("WATCHDOG=1", 60);
  manager.wait_for("WATCHDOG=1", 60);

  // The link goes: STATUS says so, and the watchdog keeps being fed (a cable is no reason to restart).
  sim.reset();
  const std::string down = manager.wait_for("STATUS=machine down", 60);
  EXPECT_NE(down.find("idle"), std::string::npos) << down;
  for (int kick = 0; kick < 3; ++kick) manager.wait_for("WATCHDOG=1", 60);
  // Still down after those kicks (the monitor's reconnect attempts fail), and still kicking.
  manager.wait_for("STATUS=machine down", 60);
  manager.wait_for("WATCHDOG=1", 60);

  cmmd.process().signal(SIGTERM);
  manager.wait_for("STOPPING=1", 60);
  EXPECT_EQ(cmmd.process().wait(), 0);
}

TEST(CmmdNotify, NoWatchdogKicksForAnotherProcessesWatchdogPid) {
  // WATCHDOG_PID names another process (pid 1): cmmd sends READY=1 but never WATCHDOG=1 for a
  // watchdog that is not its own. Checked on what arrived before STOPPING=1, so the test does not
  // wait on an absence.
  const auto dir = daemon::fresh_folder("notify-pid");
  testing::CmmdInstance cmmd(dir / "cmmd", {{"driver", "sim"}});
  testing::NotifyListener manager(dir / "notify.sock");
  std::vector<std::string> launcher = testing::notify_launcher(manager, 100'000);
  launcher[2] = "export NOTIFY_SOCKET=\"$1\" WATCHDOG_USEC=\"$2\" WATCHDOG_PID=1; shift 2; exec \"$@\"";
  cmmd.start(launcher);
  manager.wait_for("READY=1", 60);
  manager.wait_for("STATUS=machine", 60);
  manager.wait_for("STATUS=machine", 60);  // two monitor rounds: 0.5 s, several watchdog periods
  cmmd.process().signal(SIGTERM);
  manager.wait_for("STOPPING=1", 60);
  EXPECT_EQ(cmmd.process().wait(), 0);
  for (const std::string& datagram : manager.received())
    EXPECT_EQ(datagram.find("WATCHDOG=1"), std::string::npos) << datagram;
}

}  // namespace
}  // namespace cmm
