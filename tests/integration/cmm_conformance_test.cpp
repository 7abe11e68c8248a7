// One conformance suite for every hal::Cmm path: the same machine, part, seed and moves must give
// the same behaviour, the same faults and the same touches whichever transport carries them.
#include <chrono>
#include <cmath>
#include <future>
#include <map>
#include <thread>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "child_process.hpp"
#include "hal/cmm.hpp"
#include "hal/grbl_cmm.hpp"
#include "hal/ippdme_cmm.hpp"
#include "hal/modbus_cmm.hpp"
#include "hal/qualification.hpp"
#include "sim/simulated_cmm.hpp"

namespace cmm {
namespace {

using hal::Vec3;
using Clock = std::chrono::steady_clock;

// The default scene: the case-3 block (88 × 95 × 41 mm) with its corner at plate (50, 25), the
// plate's corner at M (200, 300, 0), so the block spans M x 250–338, y 325–420, z 0–41.
const Vec3 kBlockCorner(250, 325, 0);
constexpr double kTop = 41, kSigma = 0.001, kRadius = 1.0;

nlohmann::json base_config() {
  return {{"part", {{"analytic", "case3_block"}, {"edge_length_mm", 2}}}, {"trigger_sigma_mm", kSigma}, {"seed", 42}};
}

// In-process: the simulator as a library.
struct InProcessPath {
  static std::string name() { return "in-process"; }
  hal::Cmm& open(const nlohmann::json& config) {
    cmm = std::make_unique<sim::SimulatedCmm>(CMMD_SOURCE_DIR);
    cmm->configure(config);
    cmm->connect();
    cmm->enable();
    return *cmm;
  }
  std::unique_ptr<sim::SimulatedCmm> cmm;
};

// Modbus TCP: the driver against cmm-sim on loopback, started with the same config.
struct ModbusPath {
  static std::string name() { return "ModbusTcp"; }
  hal::Cmm& open(const nlohmann::json& config) {
    cmm.reset();
    sim.reset();
    const auto file = std::filesystem::path(::testing::TempDir()) / ("cmm-sim-" + std::to_string(getpid()) + ".json");
    std::ofstream(file) << config.dump();
    sim = std::make_unique<testing::ChildProcess>(
        std::vector<std::string>{CMMD_BINARY_DIR "/sim/cmm-sim", "--config", file.string(), "--port", "0"});
    const auto ready = nlohmann::json::parse(sim->read_line(60));
    cmm = std::make_unique<hal::ModbusCmm>();
    cmm->configure({{"driver", "modbus"}, {"port", ready.at("modbus_tcp")},
                    {"response_timeout_s", config.value("timeout_s", 5.0)}, {"poll_interval_s", 0.0002}});
    cmm->connect();
    cmm->enable();
    return *cmm;
  }
  std::unique_ptr<testing::ChildProcess> sim;
  std::unique_ptr<hal::ModbusCmm> cmm;
};

// Grbl 1.1 on a serial line: socat makes a pty pair, cmm-sim serves one end, the driver opens the
// other. Grbl knows no tips, travel box or sphere, so the driver's config carries the machine's.
struct GrblPath {
  static std::string name() { return "Grbl"; }
  hal::Cmm& open(const nlohmann::json& config) {
    cmm.reset();
    sim.reset();
    socat.reset();
    const auto dir = std::filesystem::path(::testing::TempDir()) / ("cmm-grbl-" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    const auto a = dir / "a", b = dir / "b";
    std::filesystem::remove(a), std::filesystem::remove(b);
    socat = std::make_unique<testing::ChildProcess>(std::vector<std::string>{
        "/usr/bin/socat", "pty,raw,echo=0,link=" + a.string(), "pty,raw,echo=0,link=" + b.string()});
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (!(std::filesystem::exists(a) && std::filesystem::exists(b)) && Clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    const auto file = dir / "sim.json";
    std::ofstream(file) << config.dump();
    sim = std::make_unique<testing::ChildProcess>(std::vector<std::string>{
        CMMD_BINARY_DIR "/sim/cmm-sim", "--config", file.string(), "--port", "0", "--grbl-device", a.string()});
    const auto ready = nlohmann::json::parse(sim->read_line(60));
    if (!ready.value("ready", false)) throw std::runtime_error("cmm-sim did not come up");
    // The driver knows the machine by the same description the simulator was given.
    const auto machine = sim::sim_config_from_json(config, CMMD_SOURCE_DIR).machine;
    cmm = std::make_unique<hal::GrblCmm>();
    cmm->configure({{"driver", "grbl"}, {"device", b.string()}, {"reset_on_open", false},
                    {"response_timeout_s", config.value("timeout_s", 5.0)}, {"status_timeout_s", 0.5},
                    {"poll_interval_s", 0.002}, {"machine", description::to_json(machine)}});
    cmm->connect();
    cmm->enable();
    return *cmm;
  }
  // Destroyed in this order: the driver, then the simulator, then the line between them.
  std::unique_ptr<testing::ChildProcess> socat;
  std::unique_ptr<testing::ChildProcess> sim;
  std::unique_ptr<hal::GrblCmm> cmm;
};

// I++ DME: the client driver against cmm-sim's I++ server on loopback, as against a commercial
// controller. The server reports no travel box or tips, so the driver's config carries the machine's.
// `pending_on_error`: cmm-sim's answer to the transactions queued behind an error, "answer" as the
// specification or "drop" as NIST's test-suite server.
struct IppDmePath {
  static std::string name() { return "IppDme"; }
  hal::Cmm& open(const nlohmann::json& config, const std::string& pending_on_error = "answer") {
    cmm.reset();
    sim.reset();
    const auto file = std::filesystem::path(::testing::TempDir()) / ("cmm-sim-ippdme-" + std::to_string(getpid()) + ".json");
    std::ofstream(file) << config.dump();
    sim = std::make_unique<testing::ChildProcess>(
        std::vector<std::string>{CMMD_BINARY_DIR "/sim/cmm-sim", "--config", file.string(), "--port", "0", "--ippdme", "0",
                                 "--ippdme-pending-on-error", pending_on_error});
    const auto ready = nlohmann::json::parse(sim->read_line(60));
    const auto machine = sim::sim_config_from_json(config, CMMD_SOURCE_DIR).machine;
    cmm = std::make_unique<hal::IppDmeCmm>();
    // move_report_s is the driver's default: 0.1 s, the least I++ DME 1.4.3 §6.3.2.7 allows.
    cmm->configure({{"driver", "ippdme"}, {"port", ready.at("ippdme")},
                    {"timeouts", {{"response_s", config.value("timeout_s", 5.0)}}},
                    {"machine", description::to_json(machine)}});
    cmm->connect();
    cmm->enable();
    return *cmm;
  }
  std::unique_ptr<testing::ChildProcess> sim;
  std::unique_ptr<hal::IppDmeCmm> cmm;
};

// Touches per path from SameSeedSameTouchesOnEveryPath, compared across paths at the end.
std::map<std::string, std::vector<Vec3>>& touches_by_path() {
  static std::map<std::string, std::vector<Vec3>> touches;
  return touches;
}

template <class Path>
class CmmConformance : public ::testing::Test {
 public:
  hal::Cmm& open(const nlohmann::json& overrides = nlohmann::json::object()) {
    nlohmann::json config = base_config();
    config.merge_patch(overrides);
    truth_ = std::make_unique<sim::SimulatedMachine>(sim::sim_config_from_json(config, CMMD_SOURCE_DIR));
    return path_.open(config);
  }

  // A vertical touch on the block's top at block coordinates (x, y), from the clearance plane.
  static hal::ProbeMove top_touch(double x, double y) {
    hal::ProbeMove p;
    p.start = kBlockCorner + Vec3(x, y, kTop + kRadius + 5);
    p.direction = -Vec3::UnitZ();
    p.max_travel_mm = 10;
    p.min_travel_mm = 2;
    p.speed_mm_s = 5;
    p.retract_mm = 2;
    return p;
  }
  // Up to the clearance plane, across, then the search (which descends to its start, guarded).
  static hal::TouchResult touch(hal::Cmm& cmm, const hal::ProbeMove& p) {
    const Vec3 at = cmm.status().position;
    cmm.move({Vec3(at.x(), at.y(), 60), 0});
    cmm.move({Vec3(p.start.x(), p.start.y(), 60), 0});
    return cmm.probe(p);
  }
  // Where the noise-free touch would be: the simulator's own truth, never seen by a driver.
  Vec3 truth(const hal::ProbeMove& p) const {
    auto c = truth_->true_contact(p);
    EXPECT_TRUE(c.has_value());
    return c.value_or(Vec3::Constant(NAN));
  }

  Path path_;
  std::unique_ptr<sim::SimulatedMachine> truth_;
};

using Paths = ::testing::Types<InProcessPath, ModbusPath, GrblPath, IppDmePath>;
class PathNames {
 public:
  template <class T>
  static std::string GetName(int) { return T::name() == "in-process" ? "InProcess" : T::name(); }
};
TYPED_TEST_SUITE(CmmConformance, Paths, PathNames);

TYPED_TEST(CmmConformance, HomesBeforeItMoves) {
  hal::Cmm& cmm = this->open();
  EXPECT_FALSE(cmm.status().homed);
  EXPECT_THROW(cmm.move({Vec3(300, 400, 100), 0}), hal::NotHomed);
  cmm.enable();
  cmm.home();
  hal::MachineStatus s = cmm.status();
  EXPECT_TRUE(s.homed);
  EXPECT_EQ(s.lifecycle, hal::Lifecycle::enabled);
  EXPECT_LT((s.position - cmm.info().travel_box.max).norm(), 1e-6);
}

TYPED_TEST(CmmConformance, MovesAndRefusesTargetsOutOfTravel) {
  hal::Cmm& cmm = this->open();
  cmm.home();
  cmm.move({Vec3(300, 400, 100), 50});
  EXPECT_LT((cmm.status().position - Vec3(300, 400, 100)).norm(), 1e-6);
  const double t = cmm.status().t_s;
  EXPECT_THROW(cmm.move({Vec3(300, 400, 1000), 0}), hal::SoftLimit);
  EXPECT_LT((cmm.status().position - Vec3(300, 400, 100)).norm(), 1e-6);  // refused before moving
  EXPECT_EQ(cmm.status().t_s, t);
  EXPECT_EQ(cmm.status().lifecycle, hal::Lifecycle::connected);  // a fault drops back to connected
  EXPECT_THROW(cmm.move({Vec3(300, 400, 90), 0}), hal::StateError);
  cmm.enable();
  cmm.move({Vec3(300, 400, 90), 0});
}

TYPED_TEST(CmmConformance, TouchesTheTruePartWithinTheTriggerNoise) {
  hal::Cmm& cmm = this->open();
  cmm.home();
  // Top face, away from the holes, and two side walls at mid height.
  std::vector<hal::ProbeMove> moves;
  for (auto [x, y] : std::vector<std::pair<double, double>>{{28, 28}, {60, 75}, {44, 10}, {80, 47.5}, {20, 50}})
    moves.push_back(this->top_touch(x, y));
  for (auto [start, dir] : std::vector<std::pair<Vec3, Vec3>>{{Vec3(-6, 47.5, 20), Vec3::UnitX()},
                                                             {Vec3(44, 101, 30), -Vec3::UnitY()}}) {
    hal::ProbeMove p = this->top_touch(0, 0);
    p.start = kBlockCorner + start;
    p.direction = dir;
    moves.push_back(p);
  }
  for (std::size_t i = 0; i < moves.size(); ++i) {
    hal::TouchResult r = this->touch(cmm, moves[i]);
    ASSERT_TRUE(r.contact);
    EXPECT_EQ(r.tip_id, "T1");
    EXPECT_LE((r.centre - this->truth(moves[i])).norm(), 3 * kSigma) << "touch " << i;
    // The analytic truth: the top at z = 41, the walls at block x = 0 and y = 95.
    const Vec3 c = r.centre - kBlockCorner;
    const double off = i < 5 ? c.z() - (kTop + kRadius) : i == 5 ? c.x() + kRadius : c.y() - (95 + kRadius);
    EXPECT_LE(std::abs(off), 3 * kSigma) << "touch " << i;
    EXPECT_NEAR(r.travel_mm, (r.centre - moves[i].start).norm(), 3 * kSigma);
    // Retracted along the approach, clear of the part.
    EXPECT_LT((cmm.status().position - (r.centre - moves[i].direction * moves[i].retract_mm)).norm(), 3 * kSigma + 1e-6);
  }
}

TYPED_TEST(CmmConformance, AMissIsNoContactOrAnEmptyResult) {
  hal::Cmm& cmm = this->open();
  cmm.home();
  hal::ProbeMove air = this->top_touch(-30, -15);  // over the plate, 47 mm above it
  cmm.move({Vec3(air.start.x(), air.start.y(), 60), 0});
  EXPECT_THROW(cmm.probe(air), hal::NoContact);
  EXPECT_EQ(cmm.status().fault, hal::FaultKind::no_contact);
  EXPECT_EQ(cmm.status().lifecycle, hal::Lifecycle::connected);
  cmm.enable();
  air.fail_on_miss = false;
  hal::TouchResult r = cmm.probe(air);
  EXPECT_FALSE(r.contact);
  EXPECT_NEAR(r.travel_mm, air.max_travel_mm, 1e-6);
}

TYPED_TEST(CmmConformance, AnEarlyTriggerIsAFaultNotATouch) {
  hal::Cmm& cmm = this->open();
  cmm.home();
  hal::ProbeMove close = this->top_touch(28, 28);
  close.start.z() = kTop + kRadius + 1;  // the surface is 1 mm away, the search must cover 2 first
  cmm.move({Vec3(close.start.x(), close.start.y(), 60), 0});
  EXPECT_THROW(cmm.probe(close), hal::EarlyTrigger);
  EXPECT_EQ(cmm.status().lifecycle, hal::Lifecycle::connected);
  cmm.enable();
  // A guarded move into the block stops at the contact and faults.
  cmm.move({Vec3(close.start.x(), close.start.y(), 60), 0});
  EXPECT_THROW(cmm.move({Vec3(close.start.x(), close.start.y(), 20), 0}), hal::EarlyTrigger);
  EXPECT_NEAR(cmm.status().position.z(), kTop + kRadius, 1e-6);
}

TYPED_TEST(CmmConformance, EStopLatchesUntilResetThenNeedsHoming) {
  // Homing from the power-on position takes 3.85 s of machine time; the e-stop input goes active
  // at 6 s, during the next long move.
  hal::Cmm& cmm = this->open({{"faults", {{"estop_at_s", 6}}}});
  cmm.home();
  EXPECT_THROW(cmm.move({Vec3(300, 400, 100), 0}), hal::EStop);
  hal::MachineStatus s = cmm.status();
  EXPECT_TRUE(s.estop);
  EXPECT_FALSE(s.homed);
  EXPECT_NEAR(s.t_s, 6, 1e-6);
  cmm.enable();
  EXPECT_THROW(cmm.home(), hal::EStop);
  cmm.reset();
  cmm.enable();
  EXPECT_THROW(cmm.move({Vec3(300, 400, 100), 0}), hal::NotHomed);
  cmm.enable();
  cmm.home();
  cmm.move({Vec3(300, 400, 100), 0});
}

// A long move in wall time (time_scale 4: 750 mm at 200 mm/s takes about 1 s), interrupted from
// another thread once status() shows it moving.
template <class Fixture, class Interrupt>
void interrupt_a_long_move(Fixture& fixture, Interrupt interrupt) {
  constexpr double kScale = 4, kSpeed = 200, kBraking = 200.0 * 200.0 / (2 * 1000);  // mm/s, mm
  hal::Cmm& cmm = fixture.open({{"time_scale", kScale}});
  cmm.home();
  auto running = std::async(std::launch::async, [&] { cmm.move({Vec3(300, 400, 100), 0}); });
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (!cmm.status().moving && Clock::now() < deadline) std::this_thread::yield();
  ASSERT_TRUE(cmm.status().moving);
  const auto seen = Clock::now();
  const Vec3 at = cmm.status().position;
  const auto asked = Clock::now();
  interrupt(cmm);
  const double answered_s = std::chrono::duration<double>(Clock::now() - seen).count();
  EXPECT_THROW(running.get(), hal::Aborted);
  EXPECT_LT(Clock::now() - asked, std::chrono::seconds(2));
  EXPECT_FALSE(cmm.status().moving);
  EXPECT_GT((cmm.status().position - Vec3(300, 400, 100)).norm(), 1);  // it did not finish
  // No farther than full speed for as long as the interrupt took to get through, plus braking.
  EXPECT_LT((cmm.status().position - at).norm(), kSpeed * kScale * answered_s + kBraking + 1);
}

TYPED_TEST(CmmConformance, AbortStopsAtOnceAndLatches) {
  interrupt_a_long_move(*this, [](hal::Cmm& cmm) { cmm.abort(); });
  hal::Cmm& cmm = *this->path_.cmm;
  EXPECT_TRUE(cmm.status().aborted);
  cmm.enable();
  EXPECT_THROW(cmm.move({Vec3(300, 400, 100), 0}), hal::Aborted);
  cmm.reset();
  cmm.enable();
  cmm.home();  // a dead stop may have lost the position
  cmm.move({Vec3(300, 400, 100), 0});
}

TYPED_TEST(CmmConformance, StopBrakesAndKeepsThePosition) {
  interrupt_a_long_move(*this, [](hal::Cmm& cmm) { cmm.stop(); });
  hal::Cmm& cmm = *this->path_.cmm;
  EXPECT_FALSE(cmm.status().aborted);
  EXPECT_TRUE(cmm.status().homed);
  cmm.enable();
  cmm.move({Vec3(300, 400, 100), 0});  // no reset needed
}

TYPED_TEST(CmmConformance, QualificationFindsTheTrueTip) {
  // The real T1 is 1.5 µm smaller and sits a few µm off its nominal offset.
  const Vec3 offset_error(0.004, -0.003, 0.002);
  nlohmann::json true_tip = {{"ball_radius_mm", 0.9985},
                              {"offset_error", {offset_error.x(), offset_error.y(), offset_error.z()}}};
  hal::Cmm& cmm = this->open({{"true_tips", {{"T1", true_tip}}}});
  cmm.home();
  description::TipQualification q = hal::qualify(cmm, "T1");
  EXPECT_EQ(q.touches, 9);
  EXPECT_NEAR(q.ball_radius_mm, 0.9985, 0.003);
  EXPECT_LT((q.offset - offset_error).norm(), 0.004);
  EXPECT_LT(q.residual_rms_mm, 3 * kSigma);
  description::MachineDescription info = cmm.info();
  ASSERT_TRUE(info.tips.front().qualification.has_value());
  EXPECT_EQ(info.tips.front().qualification->time_utc.size(), 20u);  // 2026-11-24T12:00:00Z
  EXPECT_NEAR(info.tips.front().ball_radius_mm, q.ball_radius_mm, 1e-6);  // wires carry nanometres
  // After qualification a touch on the top reports the ball centre where it really is.
  hal::TouchResult r = this->touch(cmm, this->top_touch(28, 28));
  EXPECT_NEAR(r.centre.z(), kTop + 0.9985, 0.006);
}

// What machine.stop relies on during a qualification: a stop() reaches only a running motion, so
// the hook before each motion ends it between two, and nothing moves after.
TYPED_TEST(CmmConformance, AQualificationEndsBetweenMotionsWhereItsHookThrows) {
  hal::Cmm& cmm = this->open();
  cmm.home();
  ASSERT_FALSE(cmm.info().tips.front().qualification.has_value());
  int motions = 0;
  Vec3 held = Vec3::Constant(NAN);
  hal::QualificationOptions options;
  options.before_motion = [&] {
    if (++motions == 5) {  // the first touch made, the ball back up, before the move across to the second
      held = cmm.status().position;
      throw hal::Fault(hal::FaultKind::aborted, "stopped between motions");
    }
  };
  EXPECT_THROW(hal::qualify(cmm, "T1", options), hal::Fault);
  EXPECT_EQ(motions, 5);
  EXPECT_LT((cmm.status().position - held).norm(), 1e-6) << "the machine moved after the hook ended the qualification";
  EXPECT_FALSE(cmm.info().tips.front().qualification.has_value()) << "a qualification cut short was recorded";

  // Once more after the last motion: a stop that came as it was sent, too late to stop it, still
  // keeps the result from being recorded.
  int calls = 0;
  const int last = 3 * options.touches + 2;  // climb, across, probe per touch; the final climb; the check
  options.before_motion = [&] {
    if (++calls == last) throw hal::Fault(hal::FaultKind::aborted, "stopped during the last motion");
  };
  EXPECT_THROW(hal::qualify(cmm, "T1", options), hal::Fault);
  EXPECT_EQ(calls, last);
  EXPECT_FALSE(cmm.info().tips.front().qualification.has_value()) << "a stopped qualification was recorded";

  // And `last` is where it is: a qualification the hook lets run calls it exactly that often.
  calls = 0;
  options.before_motion = [&] { ++calls; };
  hal::qualify(cmm, "T1", options);
  EXPECT_EQ(calls, last) << "the hook does not run once per motion and once before the result";
  EXPECT_TRUE(cmm.info().tips.front().qualification.has_value());
}

TYPED_TEST(CmmConformance, InjectedFaultsSurfaceTypedAndInTime) {
  auto within = [](auto&& f, double seconds) {
    const auto t0 = Clock::now();
    f();
    EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), seconds);
  };
  {
    hal::Cmm& cmm = this->open({{"faults", {{"drop_link_after_commands", 2}}}});
    cmm.home();
    cmm.move({Vec3(300, 400, 100), 0});
    within([&] { EXPECT_THROW(cmm.move({Vec3(300, 400, 90), 0}), hal::CommLost); }, 5);
    EXPECT_THROW(cmm.status(), hal::StateError);  // down until connect() brings it back
    cmm.connect();
    cmm.enable();
    EXPECT_TRUE(cmm.status().homed);  // the machine kept its state; nothing was replayed
    cmm.move({Vec3(300, 400, 90), 0});
  }
  {
    hal::Cmm& cmm = this->open({{"timeout_s", 0.2}, {"faults", {{"reply_delay_s", 2}}}});
    within([&] { EXPECT_THROW(cmm.home(), hal::Timeout); }, 1.5);
  }
  {
    hal::Cmm& cmm = this->open({{"faults", {{"corrupt_reply_at_command", 2}}}});
    cmm.home();
    within([&] { EXPECT_THROW(cmm.move({Vec3(300, 400, 100), 0}), hal::Protocol); }, 5);
  }
  {
    hal::Cmm& cmm = this->open({{"faults", {{"spurious_trigger_at_motion", 3}}}});
    cmm.home();
    hal::ProbeMove p = this->top_touch(28, 28);
    cmm.move({Vec3(p.start.x(), p.start.y(), 60), 0});
    within([&] { EXPECT_THROW(cmm.probe(p), hal::EarlyTrigger); }, 5);
    cmm.enable();
    EXPECT_TRUE(this->touch(cmm, p).contact);  // the next one is real
  }
}

TYPED_TEST(CmmConformance, SameSeedSameTouchesOnEveryPath) {
  auto run = [&](int seed) {
    hal::Cmm& cmm = this->open({{"seed", seed}});
    cmm.home();
    std::vector<Vec3> touches;
    for (double x : {10.0, 30.0, 60.0, 80.0})
      for (double y : {6.0, 30.0, 88.0}) touches.push_back(this->touch(cmm, this->top_touch(x, y)).centre);
    return touches;
  };
  std::vector<Vec3> first = run(7), again = run(7), other = run(8);
  ASSERT_EQ(first.size(), 12u);
  double differs = 0;
  for (std::size_t i = 0; i < first.size(); ++i) {
    EXPECT_LT((first[i] - again[i]).norm(), 1e-6) << i;
    differs = std::max(differs, (first[i] - other[i]).norm());
  }
  EXPECT_GT(differs, 1e-5);  // the seed does matter
  touches_by_path()[TypeParam::name()] = first;
  for (const auto& [name, touches] : touches_by_path())
    for (std::size_t i = 0; i < first.size(); ++i)
      EXPECT_LT((touches[i] - first[i]).norm(), 1e-6) << name << " vs " << TypeParam::name() << ", touch " << i;
}

// The I++ driver against cmm-sim's strict I++ face, answering the transactions queued behind an
// error as the specification does and dropping them as NIST's server does: one whole session.
class IppDmeStrictSim : public ::testing::TestWithParam<std::string> {
 protected:
  hal::Cmm& open(const nlohmann::json& overrides = nlohmann::json::object()) {
    nlohmann::json config = base_config();
    config.merge_patch(overrides);
    truth_ = std::make_unique<sim::SimulatedMachine>(sim::sim_config_from_json(config, CMMD_SOURCE_DIR));
    return path_.open(config, GetParam());
  }
  IppDmePath path_;
  std::unique_ptr<sim::SimulatedMachine> truth_;
};

TEST_P(IppDmeStrictSim, SessionHomeStatusQualificationAndAShortProbingJob) {
  const Vec3 offset_error(0.003, -0.002, 0.001);
  hal::Cmm& cmm = open({{"true_tips", {{"T1", {{"ball_radius_mm", 0.999}, {"offset_error", {0.003, -0.002, 0.001}}}}}}});
  // The set-up (StartSession .. StopAllDaemons, OnMoveReportE(Time(0.1)) .. Get) went through.
  hal::MachineStatus s = cmm.status();
  EXPECT_EQ(s.lifecycle, hal::Lifecycle::enabled);
  EXPECT_FALSE(s.homed);
  EXPECT_THROW(cmm.move({Vec3(300, 400, 100), 0}), hal::NotHomed);  // the server's 0507, read with IsHomed
  cmm.enable();
  cmm.home();
  s = cmm.status();
  EXPECT_TRUE(s.homed);
  EXPECT_LT((s.position - cmm.info().travel_box.max).norm(), 1e-6);
  const description::TipQualification q = hal::qualify(cmm, "T1");
  EXPECT_NEAR(q.ball_radius_mm, 0.999, 0.003);
  EXPECT_LT((q.offset - offset_error).norm(), 0.004);
  // The job: touches on the block's top and one wall, in our qualified frame.
  for (auto [x, y] : std::vector<std::pair<double, double>>{{28, 28}, {60, 75}, {80, 47.5}}) {
    hal::ProbeMove p = CmmConformance<IppDmePath>::top_touch(x, y);
    const hal::TouchResult r = CmmConformance<IppDmePath>::touch(cmm, p);
    ASSERT_TRUE(r.contact);
    EXPECT_NEAR(r.centre.z(), kTop + 0.999, 0.006) << x << ", " << y;
  }
  hal::ProbeMove wall = CmmConformance<IppDmePath>::top_touch(0, 0);
  wall.start = kBlockCorner + Vec3(-6, 47.5, 20);
  wall.direction = Vec3::UnitX();
  const hal::TouchResult r = CmmConformance<IppDmePath>::touch(cmm, wall);
  ASSERT_TRUE(r.contact);
  EXPECT_NEAR(r.centre.x(), kBlockCorner.x() - 0.999, 0.006);
  EXPECT_EQ(cmm.status().lifecycle, hal::Lifecycle::enabled);
}

// A query queued behind a search that fails (1003, severity 2) is aborted by the server: answered
// 0006 or never. The driver ends it with the search's error at once, and the session goes on.
TEST_P(IppDmeStrictSim, AQueryQueuedBehindAFailingSearchEndsWithIt) {
  // Wall time, homing without travel (it starts where it ends): a 10 mm search at 5 mm/s takes 2 s.
  hal::Cmm& cmm = open({{"time_scale", 1}, {"power_on_position", {700, 900, 450}}});
  cmm.home();
  cmm.move({Vec3(690, 890, 440), 0});
  hal::ProbeMove air;
  air.start = Vec3(690, 890, 440);  // far above anything: no GoTo first, the PtMeas is the only motion
  air.direction = -Vec3::UnitZ();
  air.max_travel_mm = 10;
  air.speed_mm_s = 5;
  auto search = std::async(std::launch::async, [&] { return cmm.probe(air); });
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (!cmm.status().moving && Clock::now() < deadline) std::this_thread::yield();
  ASSERT_TRUE(cmm.status().moving);
  const auto t0 = Clock::now();
  try {
    cmm.select_tip("T2");
    ADD_FAILURE() << "a ChangeTool queued behind a failed search ran";
  } catch (const hal::Protocol& e) {
    EXPECT_NE(std::string(e.what()).find("was never run"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("error 1003"), std::string::npos) << e.what();
  }
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(4)) << "waited for the response timeout";
  EXPECT_THROW(search.get(), hal::NoContact);
  EXPECT_EQ(cmm.status().lifecycle, hal::Lifecycle::connected);  // not dropped: no reconnect needed
  EXPECT_EQ(cmm.status().tip_id, "T1");
  cmm.enable();
  cmm.select_tip("T2");
  cmm.move({Vec3(690, 890, 430), 0});
  EXPECT_EQ(cmm.status().tip_id, "T2");
}

INSTANTIATE_TEST_SUITE_P(PendingOnError, IppDmeStrictSim, ::testing::Values("answer", "drop"),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

}  // namespace
}  // namespace cmm
