// cmmd.json's reader on what an operator may write by mistake: every problem is a
// description::FieldError naming its JSON Pointer, never another exception (which would end cmmd
// without saying where).
#include "daemon/daemon_config.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "hal/description/json_fields.hpp"

namespace cmm::daemon {
namespace {

using nlohmann::json;

std::vector<std::string> problems_of(const json& config) {
  try {
    daemon_config_from_json(config, "cmmd.json", ".");
  } catch (const description::FieldError& e) {
    return e.lines();
  }
  return {};
}

bool names(const std::vector<std::string>& problems, const std::string& text) {
  return std::any_of(problems.begin(), problems.end(), [&](const std::string& p) { return p.find(text) != std::string::npos; });
}

// Found by the daemon_config fuzz target (corpus/daemon_config/crash-655195b6…): a driver that is
// no string threw nlohmann's type_error out of the reader.
TEST(DaemonConfig, ADriverThatIsNoStringIsAProblemAtItsPointer) {
  for (const json& driver : {json(0.001), json(true), json::array({"sim"}), json::object()}) {
    const auto problems = problems_of({{"machine", {{"driver", driver}}}});
    EXPECT_TRUE(names(problems, "/machine/driver: must be a string")) << driver.dump() << ": " << ::testing::PrintToString(problems);
  }
}

TEST(DaemonConfig, AnUnknownDriverIsAProblemListingTheKnownOnes) {
  const auto problems = problems_of({{"machine", {{"driver", "ethercat"}}}});
  EXPECT_TRUE(names(problems, "/machine/driver: must be one of grbl, ippdme, modbus, serial, sim, not \"ethercat\""))
      << ::testing::PrintToString(problems);
}

TEST(DaemonConfig, SerialIsTheGrblDriverAndNoDriverIsTheSimulator) {
  EXPECT_EQ(daemon_config_from_json({{"machine", {{"driver", "serial"}, {"device", "/dev/ttyUSB0"}, {"machine", "config/machine.json"}}}},
                                    "cmmd.json", CMMD_SOURCE_DIR).driver,
            "grbl");
  EXPECT_EQ(daemon_config_from_json({{"machine", json::object()}}, "cmmd.json", ".").driver, "sim");
}

TEST(DaemonConfig, MqttIsOffByDefaultAndItsStationIsTheStationsName) {
  const DaemonConfig off = daemon_config_from_json(json::object(), "cmmd.json", ".");
  EXPECT_FALSE(off.mqtt.enabled);
  const DaemonConfig on = daemon_config_from_json(
      {{"station", "cell-4"},
       {"mqtt", {{"enabled", true}, {"broker", "broker.shop"}, {"port", 8883}, {"tls", {{"ca_file", "ca.crt"}}}}}},
      "cmmd.json", "/etc/cmmd");
  EXPECT_TRUE(on.mqtt.enabled);
  EXPECT_EQ(on.mqtt.station, "cell-4");
  EXPECT_EQ(on.mqtt.topic_prefix, "cmmd");
  EXPECT_EQ(on.mqtt.tls.ca_file, "/etc/cmmd/ca.crt");  // relative to the config's folder
}

TEST(DaemonConfig, MqttNamesThatWouldLandUnderOtherTopicsAreProblems) {
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"station", "cell/4"}}}}), "/mqtt/station: must be a topic level"));
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"station", "+"}}}}), "/mqtt/station"));
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"topic_prefix", "plant/#"}}}}), "/mqtt/topic_prefix"));
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"topic_prefix", "/plant"}}}}), "/mqtt/topic_prefix"));
  EXPECT_TRUE(problems_of({{"mqtt", {{"topic_prefix", "plant/cmm"}}}}).empty());
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"port", 0}}}}), "/mqtt/port"));
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"progress_interval_s", 0}}}}), "/mqtt/progress_interval_s: must be in [0.1"));
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"tls", {{"cert_file", "c.pem"}}}}}}), "/mqtt/tls/ca_file"));
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"tls", {{"ca_file", "ca.pem"}, {"cert_file", "c.pem"}}}}}}), "/mqtt/tls/cert_file"));
  EXPECT_TRUE(names(problems_of({{"mqtt", {{"brokr", "x"}}}}), "/mqtt/brokr"));
}

}  // namespace
}  // namespace cmm::daemon
