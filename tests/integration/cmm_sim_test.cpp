// cmm-sim as an operator starts it: the ready line, a clean exit on SIGTERM, a bad config refused
// with every problem, and the Grbl side on a pty of its own.
#include <csignal>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../tools/run_command.hpp"
#include "child_process.hpp"
#include "hal/grbl_cmm.hpp"

namespace cmm {
namespace {

TEST(CmmSim, ServesGrblOnItsOwnPtyAndExitsCleanlyOnSigterm) {
  testing::ChildProcess sim({CMMD_BINARY_DIR "/sim/cmm-sim", "--port", "0", "--grbl-pty"});
  const auto ready = nlohmann::json::parse(sim.read_line(60));
  EXPECT_TRUE(ready.at("ready").get<bool>());
  EXPECT_GT(ready.at("modbus_tcp").get<int>(), 0);
  const std::string pty = ready.at("grbl_pty");
  ASSERT_TRUE(std::filesystem::exists(pty)) << pty;

  {
    hal::GrblCmm cmm(CMMD_SOURCE_DIR);
    cmm.configure({{"driver", "grbl"}, {"device", pty}, {"reset_on_open", false}, {"machine", "config/machine.json"}});
    cmm.connect();
    cmm.enable();
    EXPECT_FALSE(cmm.status().homed);
    cmm.home();
    EXPECT_TRUE(cmm.status().homed);
    EXPECT_LT((cmm.status().position - hal::Vec3(700, 900, 450)).norm(), 1e-6);
  }
  sim.signal(SIGTERM);
  EXPECT_EQ(sim.wait(), 0);
}

TEST(CmmSim, RefusesABadConfigNamingEveryProblem) {
  const auto file = std::filesystem::path(::testing::TempDir()) / "cmm-sim-bad.json";
  std::ofstream(file) << R"({"seed": -1, "part": {"analytic": "teapot"}, "faults": {"estop": 1}})";
  const auto run = test::run_command(CMMD_BINARY_DIR "/sim/cmm-sim --config " + file.string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("3 problems"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("/part/analytic"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("/faults/estop: unknown key"), std::string::npos) << run.output;
  const auto missing = test::run_command(CMMD_BINARY_DIR "/sim/cmm-sim --config /no/such/file.json");
  EXPECT_NE(missing.exit_code, 0);
}

}  // namespace
}  // namespace cmm
