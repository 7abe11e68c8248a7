// The Modbus driver over RTU: cmm-sim answers on one end of a socat pty pair, hal::ModbusCmm talks
// to the other. A home, a touch on the true part, and a garbled frame (bad CRC) as a Protocol fault.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "hal/modbus_cmm.hpp"

namespace cmm {
namespace {

namespace fs = std::filesystem;

TEST(ModbusRtu, HomesTouchesAndReportsAGarbledFrame) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("cmm-rtu-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string sim_end = (dir / "sim").string(), driver_end = (dir / "driver").string();
  testing::ChildProcess socat({"/usr/bin/socat", "pty,raw,echo=0,link=" + sim_end, "pty,raw,echo=0,link=" + driver_end});
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!(fs::exists(sim_end) && fs::exists(driver_end)) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::yield();
  ASSERT_TRUE(fs::exists(sim_end) && fs::exists(driver_end)) << "socat made no pty pair";

  const fs::path config = dir / "sim.json";
  std::ofstream(config) << nlohmann::json{{"faults", {{"corrupt_reply_at_command", 4}}}}.dump();
  testing::ChildProcess sim({CMMD_BINARY_DIR "/sim/cmm-sim", "--port", "0", "--config", config.string(),
                             "--modbus-rtu", sim_end});
  ASSERT_EQ(nlohmann::json::parse(sim.read_line(60)).at("modbus_rtu"), sim_end);

  hal::ModbusCmm cmm;
  cmm.configure({{"driver", "modbus"}, {"transport", "rtu"}, {"device", driver_end}, {"baud", 115200},
                 {"response_timeout_s", 0.5}});
  cmm.connect();
  cmm.enable();
  EXPECT_EQ(cmm.info().tips.size(), 2u);
  cmm.home();                                  // command 1
  cmm.move({hal::Vec3(278, 353, 60), 0});      // 2: above the case-3 block's top at block (28, 28)
  hal::ProbeMove p;
  p.start = hal::Vec3(278, 353, 47);
  p.direction = -hal::Vec3::UnitZ();
  p.max_travel_mm = 10;
  p.min_travel_mm = 2;
  hal::TouchResult touch = cmm.probe(p);       // 3
  ASSERT_TRUE(touch.contact);
  EXPECT_NEAR(touch.centre.z(), 42, 0.003);    // the top at 41, ball radius 1, 1 µm trigger noise
  EXPECT_THROW(cmm.move({hal::Vec3(278, 353, 60), 0}), hal::Protocol);  // 4: bad CRC
  cmm.enable();
  cmm.move({hal::Vec3(278, 353, 70), 0});      // the line recovers
  EXPECT_NEAR(cmm.status().position.z(), 70, 1e-6);
  cmm.disconnect();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cmm
