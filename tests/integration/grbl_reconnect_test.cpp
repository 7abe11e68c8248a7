// Reconnecting to a Grbl machine that still runs a line from before the link went quiet: Grbl has no
// sequence numbers, so the driver must bring it to rest and flush it (feed hold, soft reset) before
// its next line, or that line would take the old one's ok for its own. cmm-sim on a socat pty pair,
// frozen by SIGSTOP for longer than the driver's status timeout.
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "hal/grbl_cmm.hpp"

namespace cmm {
namespace {

namespace fs = std::filesystem;

TEST(GrblReconnect, ALineLeftRunningByAFrozenMachineIsStoppedAndItsOkNotTakenForTheNextLines) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("cmm-grbl-freeze-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string sim_end = (dir / "sim").string(), driver_end = (dir / "driver").string();
  testing::ChildProcess socat({"/usr/bin/socat", "pty,raw,echo=0,link=" + sim_end, "pty,raw,echo=0,link=" + driver_end});
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!(fs::exists(sim_end) && fs::exists(driver_end)) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ASSERT_TRUE(fs::exists(sim_end) && fs::exists(driver_end)) << "socat made no pty pair";
  // Time scale 2: the long move below takes about 2 s of wall time, homing about as long.
  testing::ChildProcess sim({CMMD_BINARY_DIR "/sim/cmm-sim", "--port", "0", "--time-scale", "2", "--grbl-device", sim_end});
  ASSERT_TRUE(nlohmann::json::parse(sim.read_line(60)).value("ready", false));

  hal::GrblCmm cmm(CMMD_SOURCE_DIR);
  cmm.configure({{"driver", "grbl"}, {"device", driver_end}, {"reset_on_open", false}, {"status_timeout_s", 0.3},
                 {"response_timeout_s", 0.5}, {"poll_interval_s", 0.005},
                 {"machine", "config/machine.json"}});  // cmm-sim's machine
  cmm.connect();
  cmm.enable();
  cmm.home();
  const hal::Vec3 far(300, 400, 100), near(300, 400, 150);
  auto moving = std::async(std::launch::async, [&] { cmm.move({far, 0}); });
  while (!cmm.status().moving) ASSERT_NE(moving.wait_for(std::chrono::milliseconds(1)), std::future_status::ready);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  sim.signal(SIGSTOP);
  EXPECT_THROW(moving.get(), hal::CommLost);  // its `?` goes unanswered
  sim.signal(SIGCONT);  // well before the move would have ended: it runs on, unwatched

  cmm.connect();  // finds it running the old line: brings it to rest and flushes it
  hal::MachineStatus s = cmm.status();
  EXPECT_FALSE(s.moving);
  EXPECT_TRUE(s.homed);  // a hold, then the reset at rest: the position is kept
  EXPECT_GT((s.position - far).norm(), 1) << "the old line ran to its end";
  cmm.enable();
  cmm.move({near, 0});  // answered by its own ok, not the old line's
  s = cmm.status();
  EXPECT_FALSE(s.moving);
  EXPECT_LT((s.position - near).norm(), 1e-6) << "move() returned before the machine got there";
  cmm.move({near + hal::Vec3(0, 0, 10), 0});
  EXPECT_LT((cmm.status().position - near - hal::Vec3(0, 0, 10)).norm(), 1e-6);
  cmm.disconnect();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cmm
