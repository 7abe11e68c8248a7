// The Modbus heartbeat: a machine whose client goes quiet mid-command brakes and reports CommLost;
// a driver that beats keeps a long motion alive. Real cmm-sim, real sockets, motion in wall time.
#include <modbus/modbus.h>

#include <chrono>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "hal/modbus_cmm.hpp"
#include "hal/modbus_map.hpp"

namespace cmm {
namespace {

namespace mb = hal::modbus;

// Homing takes 3.85 s of machine time: 1.9 s of wall time at time scale 2, 0.77 s at 5.
struct SimOnLoopback {
  explicit SimOnLoopback(const char* time_scale)
      : sim({CMMD_BINARY_DIR "/sim/cmm-sim", "--port", "0", "--time-scale", time_scale}),
        port(nlohmann::json::parse(sim.read_line(60)).at("modbus_tcp").get<int>()) {}
  testing::ChildProcess sim;
  int port;
};

TEST(ModbusHeartbeat, AQuietClientStopsTheMachineWithCommLost) {
  // The stale heartbeat stops the homing ~50 ms in; the slow homing leaves a loaded machine (a
  // sanitizer build, other tests) time to notice before it would have finished.
  SimOnLoopback rig("2");
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", rig.port);
  ASSERT_EQ(modbus_connect(ctx), 0);
  ASSERT_EQ(modbus_write_register(ctx, mb::address("heartbeat_timeout"), 50), 1);  // ms
  std::uint16_t block[mb::kCommandCount] = {};
  block[0] = 1;
  block[1] = mb::Opcode::home;
  ASSERT_EQ(modbus_write_registers(ctx, mb::kCommandFirst, mb::kCommandCount, block), mb::kCommandCount);
  std::uint16_t status[mb::kStatusCount] = {};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  do {
    ASSERT_EQ(modbus_read_registers(ctx, mb::kStatusFirst, mb::kStatusCount, status), mb::kStatusCount);
  } while (status[mb::address("done_seq")] != 1 && std::chrono::steady_clock::now() < deadline);
  ASSERT_EQ(status[mb::address("done_seq")], 1);
  EXPECT_EQ(status[mb::address("done_result")], mb::to_code(hal::FaultKind::comm_lost));
  EXPECT_TRUE(status[mb::address("flags")] & mb::heartbeat_stale);
  EXPECT_FALSE(status[mb::address("flags")] & (mb::moving | mb::homed));  // stopped short of home
  std::uint16_t text[64];
  ASSERT_EQ(modbus_read_registers(ctx, mb::address("fault_text"), 64, text), 64);
  EXPECT_NE(mb::get_ascii(text, 64).find("heartbeat"), std::string::npos) << mb::get_ascii(text, 64);
  modbus_close(ctx);
  modbus_free(ctx);
}

TEST(ModbusHeartbeat, ABeatingDriverKeepsALongMotionAlive) {
  SimOnLoopback rig("5");
  hal::ModbusCmm cmm;
  // Beats every 20 ms against a 250 ms watch: slack for a loaded machine (sanitizers, two tests at once).
  cmm.configure({{"driver", "modbus"}, {"port", rig.port}, {"heartbeat_s", 0.02}, {"heartbeat_timeout_s", 0.25}});
  cmm.connect();
  cmm.enable();
  cmm.home();  // ~0.77 s of wall time, three heartbeat timeouts
  EXPECT_TRUE(cmm.status().homed);
}

}  // namespace
}  // namespace cmm
