// cmmd whose machine cannot be reached, the real binaries: machine.status and `cmmctl status` say why
// the link is down (the last connect's error) and show the e-stop unknown, until a link is made.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "broker_process.hpp"
#include "child_process.hpp"
#include "cmmd_instance.hpp"
#include "daemon/client/rpc_client.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using nlohmann::json;

const std::string kCmmctl = CMMD_BINARY_DIR "/daemon/cmmctl";

// machine.status once `wanted` accepts it: asked again on each machine.state notification, and every
// half second for a change the monitor does not notify (a connect that fails the same way again).
json status_when(daemon::RpcClient& client, const std::string& what, const std::function<bool(const json&)>& wanted,
                 double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  client.call("server.subscribe", {{"topics", {"machine"}}});
  for (;;) {
    const json s = client.call("machine.status");
    if (wanted(s)) return s;
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("machine.status not " + what + " after " + std::to_string(timeout_s) + " s: " + s.dump());
    client.wait_notification(0.5);
  }
}

bool has_connect_error(const json& s) { return s.value("connect_error", json(nullptr)).is_object(); }

std::string cmmctl_status(const testing::CmmdInstance& cmmd) {
  const auto r = test::run_command(kCmmctl + " --endpoint unix:" + (cmmd.folder() / "run" / "cmmd.sock").string() + " status");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return r.output;
}

// What machine.status and `cmmctl status` must say while the link is down because `reason`.
void expect_down_because(testing::CmmdInstance& cmmd, const std::string& reason) {
  daemon::RpcClient client = cmmd.client();
  const json down = status_when(client, "with a connect error", has_connect_error, 60);
  EXPECT_EQ(down["link"], "down") << down;
  EXPECT_EQ(down["lifecycle"], "configured") << down;
  EXPECT_TRUE(down.contains("estop") && down["estop"].is_null()) << "the e-stop cannot be read: " << down;
  EXPECT_EQ(down["connect_error"]["kind"], "CommLost") << down;
  EXPECT_THAT(down["connect_error"].value("message", ""), HasSubstr(reason)) << down;
  EXPECT_FALSE(down["connect_error"].value("utc", "").empty()) << down;
  EXPECT_EQ(down["fault"]["kind"], "CommLost") << down;
  EXPECT_THAT(down["fault"].value("message", ""), Not(HasSubstr("needs connected"))) << down;

  const std::string out = cmmctl_status(cmmd);
  EXPECT_THAT(out, HasSubstr("link down")) << out;
  EXPECT_THAT(out, HasSubstr("e-stop   unknown (the link is down)")) << out;
  EXPECT_THAT(out, HasSubstr("connect  failed ")) << out;
  EXPECT_THAT(out, HasSubstr(reason)) << out;
  EXPECT_THAT(out, Not(HasSubstr("released"))) << out;
  EXPECT_THAT(out, Not(HasSubstr("needs connected"))) << out;
}

TEST(CmmdLinkDown, ModbusMachineNobodyListensForIsDownWithItsReasonUntilItComesUp) {
  const auto dir = daemon::fresh_folder("link-down-modbus");
  const int port = testing::free_tcp_port();
  json machine = testing::modbus_block(port);
  machine["connect_attempts"] = 2;
  machine["connect_backoff_s"] = 0.05;
  testing::CmmdInstance cmmd(dir / "cmmd", machine, {{"machine_description", CMMD_SOURCE_DIR "/config/machine.json"}});
  cmmd.start();
  expect_down_because(cmmd, "cannot reach the Modbus machine at 127.0.0.1:" + std::to_string(port) + " after 2 attempts");

  // The machine comes up on that port: the monitor's next connect makes the link, clears the reason,
  // and the e-stop is read from the machine.
  testing::ChildProcess sim({CMMD_BINARY_DIR "/sim/cmm-sim", "--port", std::to_string(port)});
  sim.read_line(60);
  daemon::RpcClient client = cmmd.client();
  const json up = status_when(client, "up", [](const json& s) { return s.value("link", "") == "up"; }, 60);
  EXPECT_TRUE(up["connect_error"].is_null()) << up;
  EXPECT_EQ(up["estop"], false) << up;
  const std::string out = cmmctl_status(cmmd);
  EXPECT_THAT(out, HasSubstr("e-stop   released")) << out;
  EXPECT_THAT(out, Not(HasSubstr("connect  failed"))) << out;
}

TEST(CmmdLinkDown, GrblMachineOnADeviceThatIsNotThereIsDownWithItsReason) {
  const auto dir = daemon::fresh_folder("link-down-grbl");
  const std::string device = (dir / "no-such-tty").string();
  testing::CmmdInstance cmmd(dir / "cmmd", {{"driver", "grbl"},
                                            {"device", device},
                                            {"connect_attempts", 1},
                                            {"machine", CMMD_SOURCE_DIR "/config/machine.json"}});
  cmmd.start();
  expect_down_because(cmmd, "cannot reach the Grbl machine on " + device + " after 1 attempt");
}

}  // namespace
}  // namespace cmm
