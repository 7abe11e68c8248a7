// Reconnecting to a machine that is still running a command from before the link dropped: the
// driver stops it rather than replaying or waiting on it, and never takes its echo for a new one.
// A machine that stops answering for a while (cmm-sim frozen by SIGSTOP) answers late: the driver
// drops the link rather than read those answers as the next requests'.
#include <modbus/modbus.h>
#include <signal.h>

#include <chrono>
#include <future>
#include <stdexcept>
#include <thread>
#include <vector>

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

// cmm-sim frozen (SIGSTOP) while the driver waits for an answer, then let go (SIGCONT): the answer
// it gave up on still comes, late. The driver must not read it as the answer to its next request.
//
// A client of its own on the machine sees what the driver under test cannot hide.
struct Observer {
  explicit Observer(int port) : ctx(modbus_new_tcp("127.0.0.1", port)) {
    if (modbus_connect(ctx) != 0) throw std::runtime_error("observer: cannot connect");
  }
  ~Observer() {
    modbus_close(ctx);
    modbus_free(ctx);
  }
  std::vector<std::uint16_t> status() {
    std::vector<std::uint16_t> r(mb::kStatusCount);
    if (modbus_read_registers(ctx, mb::kStatusFirst, mb::kStatusCount, r.data()) != mb::kStatusCount)
      throw std::runtime_error(std::string("observer: ") + modbus_strerror(errno));
    return r;
  }
  bool busy() { return status()[mb::address("flags")] & mb::busy; }
  std::uint16_t done_seq() { return status()[mb::address("done_seq")]; }
  hal::Vec3 position() {
    const auto r = status();
    const std::uint16_t* p = &r[mb::address("position_x")];
    return hal::Vec3(mb::get_i32(p), mb::get_i32(p + 2), mb::get_i32(p + 4)) * 1e-6;
  }
  modbus_t* ctx;
};

struct FrozenSim {
  // Time scale 4: homing takes about a second of wall time, the long move below about as long.
  FrozenSim() : sim({CMMD_BINARY_DIR "/sim/cmm-sim", "--port", "0", "--time-scale", "4"}),
                port(nlohmann::json::parse(sim.read_line(60)).at("modbus_tcp").get<int>()) {}
  void freeze() {
    sim.signal(SIGSTOP);
    frozen = std::chrono::steady_clock::now();
  }
  // Lets it go once it has been frozen for `at_least`.
  void let_go(std::chrono::milliseconds at_least) {
    std::this_thread::sleep_until(frozen + at_least);
    sim.signal(SIGCONT);
  }
  // Lets it go, and waits until it has answered what it owed and no command runs any more (one left
  // running unwatched would run to its end).
  void thaw(std::chrono::milliseconds at_least) {
    let_go(at_least);
    Observer observer(port);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (observer.busy()) {
      if (std::chrono::steady_clock::now() > deadline) throw std::runtime_error("cmm-sim stays busy");
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  testing::ChildProcess sim;
  int port;
  std::chrono::steady_clock::time_point frozen;
};

// Beats every 50 ms against a 500 ms watch; an answer is given up on after 0.3 s.
nlohmann::json short_timeouts(int port) {
  return {{"driver", "modbus"}, {"port", port}, {"response_timeout_s", 0.3}, {"heartbeat_s", 0.05},
          {"heartbeat_timeout_s", 0.5}};
}

// The driver on the rig with short_timeouts, enabled and homed: where each freeze begins.
void bring_up(hal::ModbusCmm& cmm, const FrozenSim& rig) {
  cmm.configure(short_timeouts(rig.port));
  cmm.connect();
  cmm.enable();
  cmm.home();
}

TEST(ModbusReconnect, AMachineFrozenMidMotionDropsTheLinkAndNoLateAnswerIsReadAsTheNextOnes) {
  FrozenSim rig;
  hal::ModbusCmm cmm;
  bring_up(cmm, rig);
  const hal::Vec3 far(300, 400, 100), near(300, 400, 150);
  auto moving = std::async(std::launch::async, [&] { cmm.move({far, 0}); });
  while (!cmm.status().moving) ASSERT_NE(moving.wait_for(std::chrono::milliseconds(1)), std::future_status::ready);
  rig.freeze();
  EXPECT_THROW(moving.get(), hal::Timeout);
  // Its answer is still to come: the link is dropped, not left one answer behind.
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - rig.frozen).count(), 2.0);
  EXPECT_THROW(cmm.status(), hal::StateError);
  rig.thaw(std::chrono::milliseconds(800));  // longer than the machine's heartbeat watch: it brakes

  Observer observer(rig.port);
  const std::uint16_t timed_out = observer.done_seq();  // the move's echo (braked or finished), never replayed
  const hal::Vec3 where = observer.position();
  // A motion asked for before the reconnect is refused here, without reaching the machine; with the
  // link left up it went out, came back "Invalid data" (a late answer) and ran all the same.
  EXPECT_THROW(cmm.enable(), hal::StateError);
  EXPECT_THROW(cmm.move({near, 0}), hal::StateError);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(observer.done_seq(), timed_out) << "a command the driver reported as failed ran on the machine";
  EXPECT_LT((observer.position() - where).norm(), 1e-6) << "the machine moved after the driver reported a failure";

  cmm.connect();  // re-reads the machine: nothing running, the sequence from its done_seq
  cmm.enable();
  EXPECT_LT((cmm.status().position - where).norm(), 1e-6);  // its own answer, not a late one
  cmm.move({near, 0});
  EXPECT_EQ(observer.done_seq(), static_cast<std::uint16_t>(timed_out + 1)) << "one command, the next number";
  EXPECT_LT((cmm.status().position - near).norm(), 1e-6);
  EXPECT_LT((observer.position() - near).norm(), 1e-6);
}

TEST(ModbusReconnect, ABeatLeftUnansweredWhileIdleDropsTheLinkAndConnectBringsItBack) {
  FrozenSim rig;
  hal::ModbusCmm cmm;
  bring_up(cmm, rig);
  const hal::Vec3 home = cmm.status().position;
  rig.freeze();
  rig.let_go(std::chrono::milliseconds(700));  // a beat went out and was given up on
  // Only the heartbeat used the status context meanwhile, and its late answers are arriving: the
  // link is dropped, so none of them is taken for (or fails) a status poll.
  EXPECT_THROW(cmm.status(), hal::StateError);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  cmm.connect();
  cmm.enable();
  for (int i = 0; i < 20; ++i) EXPECT_LT((cmm.status().position - home).norm(), 1e-6);
  const hal::Vec3 below = home - hal::Vec3(0, 0, 10);
  cmm.move({below, 0});
  EXPECT_LT((cmm.status().position - below).norm(), 1e-6);
}

}  // namespace
}  // namespace cmm
