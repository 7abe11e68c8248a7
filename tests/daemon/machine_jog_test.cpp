// MachineJog on the in-process simulator behind a recording hal::Cmm: a step ends where it should, a
// face stops it short (never beyond), a contact stops it and it goes no further, a lease not renewed
// runs out within hold_s and a segment, and it is refused while a job holds the machine or unhomed.
#include "daemon/machine_jog.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <thread>

#include "daemon/client/rpc_error.hpp"
#include "daemon/driver_factory.hpp"
#include "fresh_folder.hpp"
#include "hal/description/json_fields.hpp"
#include "recording_cmm.hpp"

namespace cmm::daemon {
namespace {

using nlohmann::json;
using testing::RecordedCommand;
using testing::RecordingCmm;
using Clock = std::chrono::steady_clock;

#ifdef CMMD_SANITIZED
constexpr double kSlackS = 0.5;  // the sanitizers' slowdown, on top of a loaded machine's
#else
constexpr double kSlackS = 0.25;
#endif

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// The default machine (travel box (-100, -100, -50) – (700, 900, 450), T1's ball radius 1 mm) with
// the default plate at (200, 300, 0) in M, its top face at z = 0; on a virtual clock, so that the
// jog's own pacing is the only thing that takes wall time.
class MachineJogTest : public ::testing::Test {
 protected:
  void start(const hal::Vec3& home, JogOptions options = {50, 0.1}, bool homed = true) {
    const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
    jog_.reset();  // before the machine it jogs
    const auto dir = fresh_folder(std::string("jog-") + test->name());
    // Powered on where it homes: homing goes down before across, which could meet the part.
    const json at = {home.x(), home.y(), home.z()};
    const json block = {{"driver", "sim"}, {"home_position", at}, {"power_on_position", at}, {"seed", 1}};
    auto recorder = std::make_unique<RecordingCmm>(make_driver("sim", dir.string()));
    recorder_ = recorder.get();
    link_ = std::make_unique<MachineLink>(std::move(recorder), block, "sim");
    link_->bring_up();
    box_ = link_->cmm().info().travel_box;
    if (homed) link_->cmm().home();
    recorder_->commands.clear();
    jog_ = std::make_unique<MachineJog>(*link_, options, box_);
  }

  JogRequest step(const hal::Vec3& direction, double distance_mm, double speed_mm_s = 50) const {
    JogRequest r;
    r.direction = direction.normalized();
    r.speed_mm_s = speed_mm_s;
    r.distance_mm = distance_mm;
    return r;
  }
  JogRequest held(const hal::Vec3& direction, double speed_mm_s = 5, double hold_s = 0.3) const {
    JogRequest r;
    r.direction = direction.normalized();
    r.speed_mm_s = speed_mm_s;
    r.hold_s = hold_s;
    return r;
  }

  // Polls until the jog has ended; fails the test after `timeout_s`.
  JogEnd wait_for_end(double timeout_s = 10) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (jog_->running()) {
      if (Clock::now() > deadline) {
        ADD_FAILURE() << "the jog did not end within " << timeout_s << " s";
        jog_->stop();
        break;
      }
      std::this_thread::yield();
    }
    while (jog_->running()) std::this_thread::yield();
    return jog_->last_end().value_or(JogEnd{});
  }

  // The RpcError a jog is refused with (a failure when it is not refused).
  RpcError refusal(const JogRequest& r) {
    try {
      jog_->jog(r, "client A");
    } catch (const RpcError& e) {
      return e;
    }
    ADD_FAILURE() << "the jog was not refused";
    wait_for_end();
    return RpcError(0, "not refused");
  }

  hal::Vec3 ball() { return link_->cmm().status().position; }
  std::size_t moves() const { return recorder_->commands.size(); }

  RecordingCmm* recorder_ = nullptr;
  std::unique_ptr<MachineLink> link_;
  description::TravelBox box_;
  std::unique_ptr<MachineJog> jog_;
};

TEST_F(MachineJogTest, AStepJogEndsAtItsStartPlusDirectionTimesDistanceInSegmentsOfAtMostSegmentS) {
  start({100, 100, 100});
  const hal::Vec3 d = hal::Vec3(1, 2, -2).normalized();
  const MachineJog::Started s = jog_->jog(step({1, 2, -2}, 12), "client A");
  EXPECT_FALSE(s.renewed);
  EXPECT_LT((s.position - hal::Vec3(100, 100, 100)).norm(), 1e-9);
  const JogEnd end = wait_for_end();
  EXPECT_EQ(end.id, s.id);
  EXPECT_FALSE(end.fault) << end.reason;
  EXPECT_EQ(end.reason, "travelled 12.000 mm");
  EXPECT_LT((ball() - (s.position + 12 * d)).norm(), 1e-9) << ball().transpose();
  // 50 mm/s × 0.1 s: 5 + 5 + 2 mm, each a guarded move at the jog's speed, each a step along the line.
  ASSERT_EQ(moves(), 3u);
  hal::Vec3 from = s.position;
  for (const RecordedCommand& c : recorder_->commands) {
    EXPECT_EQ(c.kind, RecordedCommand::Kind::move);
    EXPECT_EQ(c.move.speed_mm_s, 50);
    EXPECT_LE((c.move.target - from).norm(), 5 + 1e-9);
    EXPECT_GT((c.move.target - from).normalized().dot(d), 1 - 1e-9);
    from = c.move.target;
  }
  EXPECT_TRUE(jog_->status_json().is_null());
  EXPECT_EQ(jog_->last_json()["reason"], "travelled 12.000 mm");
}

TEST_F(MachineJogTest, AJogTowardAFaceStopsAtTheFaceLessTheBallRadiusAndTheNextOneThatWayIsRefused) {
  start({688, 100, 100});
  jog_->jog(step({1, 0, 0}, 100), "client A");
  const JogEnd at_face = wait_for_end();
  EXPECT_FALSE(at_face.fault) << at_face.reason;
  EXPECT_EQ(at_face.reason, "at the travel box's +x face");
  EXPECT_NEAR(ball().x(), 699, 1e-9) << "700 less T1's ball radius";
  for (const RecordedCommand& c : recorder_->commands) EXPECT_LE(c.move.target.x(), 699 + 1e-9);
  const std::size_t before = moves();
  for (const hal::Vec3& toward : {hal::Vec3(1, 0, 0), hal::Vec3(1, 1, 0)}) {
    const RpcError e = refusal(step(toward, 5));
    EXPECT_EQ(e.code(), rpc_code::machine_fault) << e.what();
    EXPECT_EQ(e.data().value("kind", ""), "SoftLimit") << e.data();
    EXPECT_EQ(e.data().value("face", ""), "+x") << e.data();
    EXPECT_NE(std::string(e.what()).find("+x face (x ≤ 699.000"), std::string::npos) << e.what();
  }
  EXPECT_EQ(moves(), before) << "a refused jog does not move";
  jog_->jog(step({-1, 0, 0}, 4), "client A");
  EXPECT_EQ(wait_for_end().reason, "travelled 4.000 mm");
  EXPECT_NEAR(ball().x(), 695, 1e-9);
}

TEST_F(MachineJogTest, ABallHomedToTheBoxCornerJogsBackInAlongAnAxisItIsAtTheFaceOf) {
  start({700, 900, 450});  // the default home: every + face at once
  jog_->jog(step({0, 0, -1}, 5), "client A");
  const JogEnd end = wait_for_end();
  EXPECT_FALSE(end.fault) << end.reason;
  EXPECT_LT((ball() - hal::Vec3(700, 900, 445)).norm(), 1e-9);
  EXPECT_EQ(refusal(step({0, 1, -1}, 5)).data().value("face", ""), "+y");
}

TEST_F(MachineJogTest, AContactStopsTheJogWithEarlyTriggerAndTheMachineGoesNoFurther) {
  // Above the plate near corner 2, clear of the part: the ball meets the plate's top (z = 0) at z = 1.
  start({390, 310, 8});
  const std::size_t none = moves();
  jog_->jog(step({0, 0, -1}, 20), "client A");
  const JogEnd end = wait_for_end();
  ASSERT_TRUE(end.fault) << end.reason;
  EXPECT_EQ(*end.fault, hal::FaultKind::early_trigger) << end.reason;
  EXPECT_NEAR(ball().z(), 1, 0.01) << "stopped at the contact";
  EXPECT_EQ(moves() - none, 2u) << "8 → 3, then the segment toward −2 that met the plate; nothing after it";
  const hal::MachineStatus status = link_->cmm().status();
  ASSERT_TRUE(status.fault);
  EXPECT_EQ(*status.fault, hal::FaultKind::early_trigger) << "machine.status shows the contact";
  EXPECT_EQ(jog_->last_json()["fault"], "EarlyTrigger");

  // On into it (a dashboard button still held, or pressed again) is refused without a motion.
  for (const hal::Vec3& into : {hal::Vec3(0, 0, -1), hal::Vec3(1, 0, -1)}) {
    const RpcError e = refusal(held(into));
    EXPECT_EQ(e.code(), rpc_code::machine_fault) << e.what();
    EXPECT_EQ(e.data().value("kind", ""), "EarlyTrigger") << e.what();
  }
  EXPECT_EQ(moves() - none, 2u);
  EXPECT_NEAR(ball().z(), 1, 0.01);

  // Backing off needs no reset: the opposite way leaves the contact, and the fault clears.
  jog_->jog(step({0, 0, 1}, 3), "client A");
  const JogEnd back = wait_for_end();
  EXPECT_FALSE(back.fault) << back.reason;
  EXPECT_NEAR(ball().z(), 4, 0.01);
  EXPECT_FALSE(link_->cmm().status().fault);
}

TEST_F(MachineJogTest, AHeldJogRunsWhileRenewedAndStopsWithinHoldAndASegmentOnceReleased) {
  start({100, 100, 100}, {5, 0.1});
  const Clock::time_point t0 = Clock::now();
  const MachineJog::Started first = jog_->jog(held({1, 0, 0}, 5, 0.3), "client A");
  // Renewed every 50 ms for 0.8 s, as a dashboard button held down is re-sent.
  while (since(t0) < 0.8) {
    const MachineJog::Started again = jog_->jog(held({1, 0, 0}, 5, 0.3), "client A");
    EXPECT_TRUE(again.renewed);
    EXPECT_EQ(again.id, first.id);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the client's cadence, not a wait for a result
  }
  const Clock::time_point released = Clock::now();
  EXPECT_TRUE(jog_->running()) << "renewed, it must not have run out: " << jog_->last_json();
  EXPECT_EQ(jog_->status_json().value("id", 0), first.id);
  const JogEnd end = wait_for_end();
  const double after_release_s = since(released), total_s = since(t0);
  EXPECT_EQ(end.reason, "released (no machine.jog within hold_s)");
  EXPECT_LE(after_release_s, 0.3 + 0.1 + kSlackS);
  const double travelled = ball().x() - 100;
  EXPECT_GT(travelled, 5 * 0.8 * 0.5) << "it moved while held";
  EXPECT_LE(travelled, 5 * total_s + 1e-9) << "never faster than 5 mm/s on the wall clock";
  EXPECT_LT(std::abs(ball().y() - 100) + std::abs(ball().z() - 100), 1e-9);
}

// Two dashboards, one jog: while client A's jog runs, client B can neither renew nor replace it, so it
// ends when its owner lets go, whatever B keeps sending; after that B's call starts a jog of its own.
// Either may stop a jog.
TEST_F(MachineJogTest, OnlyTheClientThatStartedAJogRenewsItAndAnyClientStopsIt) {
  start({100, 100, 100}, {5, 0.1});
  const Clock::time_point t0 = Clock::now();
  const MachineJog::Started a = jog_->jog(held({1, 0, 0}, 5, 0.3), "client A");
  int refused = 0;
  std::optional<MachineJog::Started> own;  // B's first call taken: a jog of B's own
  while (!own && since(t0) < 2.0) {  // B keeps "holding" its button; A let go at once
    try {
      own = jog_->jog(held({1, 0, 0}, 5, 0.3), "client B");
    } catch (const RpcError& e) {
      EXPECT_EQ(e.code(), rpc_code::machine_busy);
      EXPECT_NE(std::string(e.what()).find("another client (client A)"), std::string::npos) << e.what();
      ++refused;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the client's cadence, not a wait for a result
  }
  ASSERT_TRUE(own) << "B never got a jog of its own";
  const std::optional<JogEnd> a_end = jog_->last_end();
  ASSERT_TRUE(a_end);
  EXPECT_EQ(a_end->id, a.id) << "A's jog had not ended when B's was taken";
  EXPECT_EQ(a_end->reason, "released (no machine.jog within hold_s)");
  EXPECT_NE(own->id, a.id);
  EXPECT_FALSE(own->renewed) << "B renewed A's jog";
  EXPECT_GT(refused, 2) << "B's calls while A's jog ran";
  EXPECT_LE(own->position.x() - 100, 5 * (0.3 + 0.1) + 1e-9) << "A's jog ran on after its owner let go";

  jog_->stop();  // as machine.jog_stop from client A: a stop needs no ownership
  EXPECT_EQ(wait_for_end().reason, "stopped by machine.jog_stop");
}

TEST_F(MachineJogTest, AJogNeverRenewedStopsWithinHoldAndOneSegment) {
  start({100, 100, 100}, {5, 0.1});
  const Clock::time_point t0 = Clock::now();
  jog_->jog(held({0, -1, 0}, 5, 0.3), "client A");
  const JogEnd end = wait_for_end();
  EXPECT_EQ(end.reason, "released (no machine.jog within hold_s)");
  EXPECT_LE(since(t0), 0.3 + 0.1 + kSlackS);
  EXPECT_LE(100 - ball().y(), 5 * (0.3 + 0.1) + 1e-9);
  EXPECT_GT(100 - ball().y(), 0);
}

TEST_F(MachineJogTest, ADifferentDirectionReplacesTheJogAndJogStopEndsIt) {
  start({100, 100, 100}, {5, 0.1});
  const MachineJog::Started x = jog_->jog(held({1, 0, 0}, 5, 1), "client A");
  const MachineJog::Started y = jog_->jog(held({0, 1, 0}, 5, 1), "client A");
  EXPECT_NE(y.id, x.id);
  EXPECT_FALSE(y.renewed);
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (ball().y() < 100.5 && Clock::now() < deadline) std::this_thread::yield();
  EXPECT_GE(ball().y(), 100.5) << "the replacing jog moves along +y";
  EXPECT_EQ(jog_->status_json().value("id", 0), y.id);
  const Clock::time_point stopped = Clock::now();
  jog_->stop();
  const JogEnd end = wait_for_end();
  EXPECT_LE(since(stopped), 0.1 + kSlackS);
  EXPECT_EQ(end.id, y.id);
  EXPECT_EQ(end.reason, "stopped by machine.jog_stop");
  EXPECT_EQ(end.fault, hal::FaultKind::aborted);
  EXPECT_LE(ball().x() - 100, 0.5 + 1e-9) << "the +x jog ran a segment at most";
}

TEST_F(MachineJogTest, MachineStopEndsAJog) {
  start({100, 100, 100}, {5, 0.1});
  jog_->jog(held({0, 0, 1}, 5, 1), "client A");
  link_->count_stop();  // what machine.stop does, with the machine's own stop
  link_->cmm().stop();
  const JogEnd end = wait_for_end(2);
  ASSERT_TRUE(end.fault) << end.reason;
  EXPECT_EQ(*end.fault, hal::FaultKind::aborted);
}

TEST_F(MachineJogTest, RefusedWhileAJobHoldsTheMachineAndWhenNotHomed) {
  start({100, 100, 100});
  {
    const auto lease = link_->try_lease("job 3");
    ASSERT_TRUE(lease);
    const RpcError e = refusal(step({1, 0, 0}, 5));
    EXPECT_EQ(e.code(), rpc_code::machine_busy) << e.what();
    EXPECT_EQ(e.data().value("holder", ""), "job 3");
  }
  EXPECT_EQ(moves(), 0u);
  // While a jog runs, the machine is its: machine.home (or a job) finds it busy.
  jog_->jog(held({1, 0, 0}, 5, 1), "client A");
  EXPECT_EQ(link_->holder().value_or(""), "machine.jog");
  jog_->stop();
  wait_for_end();

  start({100, 100, 100}, {50, 0.1}, false);
  const RpcError e = refusal(step({1, 0, 0}, 5));
  EXPECT_EQ(e.code(), rpc_code::machine_fault) << e.what();
  EXPECT_EQ(e.data().value("kind", ""), "NotHomed");
  EXPECT_EQ(moves(), 0u);
}

TEST(JogRequest, IsCheckedFieldByFieldAgainstTheConfiguredLimits) {
  const JogOptions options{5, 0.1};
  const JogRequest r = jog_request_from_json({{"direction", {0, 3, -4}}, {"distance_mm", 2}}, options);
  EXPECT_LT((r.direction - hal::Vec3(0, 0.6, -0.8)).norm(), 1e-12);
  EXPECT_EQ(r.speed_mm_s, 5) << "the configured limit is the default";
  EXPECT_EQ(r.distance_mm, 2);
  EXPECT_EQ(r.hold_s, 0.3);
  EXPECT_FALSE(jog_request_from_json({{"direction", {1, 0, 0}}}, options).distance_mm);
  // Components whose squares overflow still give a unit direction, not a zero one.
  const JogRequest huge = jog_request_from_json({{"direction", {1e308, -1e308, 0}}}, options);
  EXPECT_LT((huge.direction - hal::Vec3(1, -1, 0).normalized()).norm(), 1e-12);

  const auto path_of = [&](const json& params) {
    try {
      jog_request_from_json(params, options);
    } catch (const RpcError& e) {
      EXPECT_EQ(e.code(), rpc_code::invalid_params) << e.what();
      return e.data().value("path", std::string("?"));
    }
    return std::string("accepted");
  };
  EXPECT_EQ(path_of({{"direction", {0, 0, 0}}}), "/direction");
  EXPECT_EQ(path_of({{"direction", {0, 0}}}), "/direction");
  EXPECT_EQ(path_of(json::object()), "/direction");
  EXPECT_EQ(path_of({{"direction", {1, 0, 0}}, {"speed_mm_s", 6}}), "/speed_mm_s");
  EXPECT_EQ(path_of({{"direction", {1, 0, 0}}, {"speed_mm_s", 0}}), "/speed_mm_s");
  EXPECT_EQ(path_of({{"direction", {1, 0, 0}}, {"distance_mm", -1}}), "/distance_mm");
  EXPECT_EQ(path_of({{"direction", {1, 0, 0}}, {"hold_s", 2}}), "/hold_s");
  EXPECT_EQ(path_of({{"direction", {1, 0, 0}}, {"speed", 2}}), "/speed");
  EXPECT_EQ(path_of(json::array()), "");
  try {
    jog_request_from_json({{"speed", 2}, {"direction", {0, 0, 0}}}, options);
    ADD_FAILURE() << "accepted";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.data()["problems"].size(), 2u) << "every bad field at once: " << e.data();
  }
}

TEST(JogReach, IsLimitedOnlyByTheFacesTheBallMovesToward) {
  description::TravelBox box;
  box.min = {0, 0, 0};
  box.max = {100, 100, 100};
  JogReach r = jog_reach(box, 1, {50, 50, 50}, {1, 0, 0});
  EXPECT_DOUBLE_EQ(r.mm, 49);
  EXPECT_EQ(r.face, "+x");
  r = jog_reach(box, 1, {50, 90, 50}, hal::Vec3(1, 1, 0).normalized());
  EXPECT_NEAR(r.mm, 9 * std::sqrt(2.0), 1e-12);
  EXPECT_EQ(r.face, "+y");
  r = jog_reach(box, 1, {100, 100, 100}, {0, 0, -1});  // at the box's corner, beyond the shrunk faces
  EXPECT_DOUBLE_EQ(r.mm, 99);
  EXPECT_EQ(r.face, "-z");
  EXPECT_EQ(jog_reach(box, 1, {100, 100, 100}, {0, 1, 0}).mm, 0) << "never negative";
}

TEST(JogConfig, DefaultsAndLimitsInCmmdJson) {
  const DaemonConfig defaults = daemon_config_from_json(json::object(), "cmmd.json", ".");
  EXPECT_EQ(defaults.jog.max_speed_mm_s, 5);
  EXPECT_EQ(defaults.jog.segment_s, 0.1);
  const DaemonConfig set = daemon_config_from_json({{"jog", {{"max_speed_mm_s", 20}, {"segment_s", 0.05}}}}, "cmmd.json", ".");
  EXPECT_EQ(set.jog.max_speed_mm_s, 20);
  EXPECT_EQ(set.jog.segment_s, 0.05);
  try {
    daemon_config_from_json({{"jog", {{"max_speed_mm_s", 500}, {"segment_s", 0}, {"hold", 1}}}}, "cmmd.json", ".");
    ADD_FAILURE() << "accepted";
  } catch (const description::FieldError& e) {
    const std::vector<std::string> lines = e.lines();
    const std::string all = ::testing::PrintToString(lines);
    EXPECT_NE(all.find("/jog/max_speed_mm_s: must not exceed the machine's max_speed_mm_s (200"), std::string::npos) << all;
    EXPECT_NE(all.find("/jog/segment_s"), std::string::npos) << all;
    EXPECT_NE(all.find("/jog/hold: unknown key"), std::string::npos) << all;
  }
}

}  // namespace
}  // namespace cmm::daemon
