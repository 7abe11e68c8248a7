// A third-party Modbus client (Debian's pymodbus) drives cmm-sim through a home and a touch using
// only docs/modbus-map.md: the document is enough to write a client.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "../tools/run_command.hpp"

namespace cmm {
namespace {

TEST(ModbusThirdParty, PymodbusHomesAndTouchesFromTheDocumentAlone) {
  testing::ChildProcess sim({CMMD_BINARY_DIR "/sim/cmm-sim", "--port", "0"});
  const auto ready = nlohmann::json::parse(sim.read_line(60));
  // The default scene: the case-3 block's top (z = 41) at block (28, 28) is M (278, 353); the
  // default tip's ball (r = 1) touches it with its centre at z = 42.
  const auto run = test::run_command(std::string(CMMD_SYSTEM_PYTHON) + " " CMMD_SOURCE_DIR
                                     "/tests/integration/modbus_third_party.py --doc " CMMD_SOURCE_DIR
                                     "/docs/modbus-map.md --port " + std::to_string(ready.at("modbus_tcp").get<int>()) +
                                     " --x 278 --y 353 --z 47");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto result = nlohmann::json::parse(run.output);
  EXPECT_EQ(result.at("contact"), 1);
  EXPECT_TRUE(result.at("homed").get<bool>());
  EXPECT_NEAR(result.at("touch_mm")[0].get<double>(), 278, 1e-6);
  EXPECT_NEAR(result.at("touch_mm")[1].get<double>(), 353, 1e-6);
  EXPECT_NEAR(result.at("touch_mm")[2].get<double>(), 42, 0.005);  // 1 µm trigger noise
}

}  // namespace
}  // namespace cmm
