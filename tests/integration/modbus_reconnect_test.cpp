// Reconnecting to a machine that is still running a command from before the link dropped: the
// driver stops it rather than replaying or waiting on it, and never takes its echo for a new one.
#include <modbus/modbus.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "hal/modbus_cmm.hpp"
#include "hal/modbus_map.hpp"

namespace cmm {
namespace {

namespace mb = hal::modbus;

TEST(ModbusReconnect, ACommandLeftRunningIsStoppedAndItsEchoNotTakenForANewOne) {
  // Time scale 2: homing takes about 2 s of wall time, long enough to be caught running.
  testing::ChildProcess sim({CMMD_BINARY_DIR "/sim/cmm-sim", "--port", "0", "--time-scale", "2"});
  const int port = nlohmann::json::parse(sim.read_line(60)).at("modbus_tcp").get<int>();

  // The client that lost its link: it started homing (sequence 1) and is gone.
  modbus_t* lost = modbus_new_tcp("127.0.0.1", port);
  ASSERT_EQ(modbus_connect(lost), 0);
  std::uint16_t block[mb::kCommandCount] = {1, mb::Opcode::home};
  ASSERT_EQ(modbus_write_registers(lost, mb::kCommandFirst, mb::kCommandCount, block), mb::kCommandCount);
  modbus_close(lost);
  modbus_free(lost);

  hal::ModbusCmm cmm;
  cmm.configure({{"driver", "modbus"}, {"port", port}});
  cmm.connect();  // finds the machine busy homing: stops it and waits for its echo
  hal::MachineStatus s = cmm.status();
  EXPECT_FALSE(s.moving);
  EXPECT_FALSE(s.homed);  // the stopped homing did not finish
  EXPECT_EQ(s.fault, hal::FaultKind::aborted);
  cmm.enable();
  EXPECT_THROW(cmm.move({hal::Vec3(300, 400, 100), 0}), hal::NotHomed);  // answered by the machine, not an old echo
  cmm.enable();
  cmm.home();
  EXPECT_TRUE(cmm.status().homed);
}

}  // namespace
}  // namespace cmm
