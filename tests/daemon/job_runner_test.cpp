// JobRunner on the in-process simulator, behind a recording hal::Cmm: each stage, and each way a run
// ends — done (its commands the plan's motions one for one, its probing time the plan's estimate),
// failed (model, plan, registration), cancelled (planning, between touches, mid-touch), paused
// (operator, stop, fault, journal write, tip), interrupted — and that a held job resumes to done
// with every touch made once.
#include "daemon/job_runner.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include "daemon/client/sha256.hpp"
#include "daemon/driver_factory.hpp"
#include "fresh_folder.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/mesh_io.hpp"
#include "hal/fault.hpp"
#include "recording_cmm.hpp"
#include "sim/raw_scan.hpp"
#include "sim/sim_config.hpp"
#include "sim/simulated_cmm.hpp"
#include "tests/tools/small_tmpfs.hpp"

namespace cmm::daemon {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;
using testing::RecordedCommand;
using testing::RecordingCmm;

// The sample part on its plate, the simulator homing to where the plan's program starts and ends
// (the travel box's low corner on the clearance plane), so that a run's commands are the plan's.
json sim_block() {
  return {{"driver", "sim"},
          {"part", {{"analytic", "case3_block"}, {"edge_length_mm", 2}}},
          {"plate_pose", {{"rotation_deg", {0, 0, 7}}, {"translation", {180, 260, 0}}}},
          {"part_pose", {{"rotation_deg", {0, 0, -4}}, {"translation", {55, 25, 0}}}},
          {"home_position", {-100, -100, 60}},
          {"trigger_sigma_mm", 0.001},
          {"seed", 3}};
}

// The plate's corners in the part's frame S (the reference mesh's) and in M: T_M_S exactly.
json given_corners(const json& block, const Eigen::Vector3d& machine_shift = Eigen::Vector3d::Zero()) {
  const sim::SimConfig truth = sim::sim_config_from_json(block);
  json corners = json::array();
  for (int id = 1; id <= truth.plate.corner_count(); ++id) {
    const Eigen::Vector3d c = truth.plate.corner(id);
    const Eigen::Vector3d scan = truth.T_P_Part.inverse() * c, machine = truth.T_M_P * c + machine_shift;
    corners.push_back({{"id", id}, {"scan", {scan.x(), scan.y(), scan.z()}},
                       {"machine", {machine.x(), machine.y(), machine.z()}}});
  }
  return {{"corners", corners}};
}

class JobRunnerTest : public ::testing::Test {
 protected:
  // A job of the sample part at 10 mm spacing (every kind of touch, a few seconds) registered by
  // given corners; `request` and `block` changes merge into the defaults.
  void start(const json& request_patch = json::object(), const json& block_patch = json::object(),
             const std::filesystem::path& jobs_dir = {}) {
    const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fresh_folder(std::string("runner-") + test->name());
    std::filesystem::create_directories(dir_ / "models");
    geometry::write_mesh(dir_ / "models" / "part.ply", geometry::make_case3_block(2).mesh);
    json block = sim_block();
    if (block_patch.is_object()) block.merge_patch(block_patch);
    json config = {{"state_dir", (dir_ / "state").string()},
                   {"runtime_dir", (dir_ / "run").string()},
                   {"models_dir", (dir_ / "models").string()},
                   {"machine", block}};
    config_.emplace(daemon_config_from_json(config, "job_runner_test", dir_));
    auto recorder = std::make_unique<RecordingCmm>(make_driver("sim", dir_.string()));
    recorder_ = recorder.get();
    link_ = std::make_unique<MachineLink>(std::move(recorder), config_->machine, "sim",
                                          config_->state_dir / "touch_in_progress.json");
    // The tips as machine.qualify leaves them (the simulator's true tips are its nominal ones here).
    link_->bring_up();
    for (const std::string& tip : qualified_) {
      description::TipQualification q;
      q.ball_radius_mm = link_->cmm().info().find_tip(tip)->ball_radius_mm;
      q.offset = link_->cmm().info().find_tip(tip)->offset;
      q.touches = 9;
      q.time_utc = "2026-12-01T07:00:00Z";
      link_->cmm().record_qualification(tip, q);
    }
    models_ = std::make_unique<ModelStore>(config_->state_dir / "models", config_->models_dir);
    store_ = std::make_unique<JobStore>(jobs_dir.empty() ? config_->state_dir / "jobs" : jobs_dir);
    json params = {{"model", "file:part.ply"}, {"spacing_mm", 10}, {"registration", given_corners(block)}};
    if (request_patch.is_object()) params.merge_patch(request_patch);
    request_.emplace(parse_job_request(params, *config_));
    id_ = store_->create(params, "test", request_->model).id;
    JobSink sink;
    sink.state = [this](JobState state, const std::string& reason, const std::optional<JobFault>& fault) {
      states_.push_back(state);
      reason_ = reason;
      fault_ = fault;
    };
    sink.progress = [](const JobProgress&) {};
    sink.touched = [this](int touch, const hal::TouchResult& r) {
      touched_.push_back(touch);
      contacts_ += r.contact;
      if (after_touch_) after_touch_(static_cast<int>(touched_.size()));
    };
    runner_ = std::make_unique<JobRunner>(RunEnvironment{*config_, *link_, *models_, *store_, "test"}, id_, *request_,
                                          control_, sink);
  }

  JobState run(bool rehome = false, bool reregister = false) {
    control_.clear();
    runner_->run(rehome, reregister);
    return states_.back();
  }

  json file(JobFile f) const {
    const std::optional<std::string> text = store_->read(id_, f);
    if (!text) throw std::runtime_error(std::string("no ") + file_name(f));
    return json::parse(*text);
  }
  std::vector<JournalEntry> journal() const { return recover_journal(store_->path(id_, JobFile::touches)).entries; }
  std::multiset<int> journalled() const {
    std::multiset<int> ids;
    for (const JournalEntry& e : journal()) ids.insert(e.touch_id);
    return ids;
  }
  std::size_t planned_touches() const { return file(JobFile::plan).at("program").size(); }
  hal::Vec3 ball() { return link_->cmm().status().position; }
  // A move below the clearance plane toward a touch: not the way back to the start after a probe.
  bool descends(std::size_t i, const RecordedCommand& c) const {
    return c.kind == RecordedCommand::Kind::move && c.move.target.z() < 59 &&
           (i == 0 || recorder_->commands[i - 1].kind != RecordedCommand::Kind::probe);
  }
  // Once the job is done, every touch of the plan is in the journal exactly once.
  void expect_every_touch_once() {
    std::multiset<int> planned;
    const json plan = file(JobFile::plan);
    for (const json& t : plan.at("program")) planned.insert(t.at("id").get<int>());
    EXPECT_EQ(journalled(), planned);
  }

  std::filesystem::path dir_;
  std::optional<DaemonConfig> config_;
  RecordingCmm* recorder_ = nullptr;
  std::unique_ptr<MachineLink> link_;
  std::unique_ptr<ModelStore> models_;
  std::unique_ptr<JobStore> store_;
  std::optional<JobRequest> request_;
  int id_ = 0;
  JobControl control_;
  std::unique_ptr<JobRunner> runner_;
  std::vector<JobState> states_;
  std::string reason_;
  std::optional<JobFault> fault_;
  std::vector<int> touched_;
  int contacts_ = 0;
  std::function<void(int touches_made)> after_touch_;
  std::vector<std::string> qualified_{"T1"};  // the tips qualified before the job
};

// The sample machine without a tool changer (a Grbl machine's kind): the operator fits each tip.
json without_tool_changer() {
  json machine = description::to_json(description::default_machine());
  machine["tool_changer"] = false;
  return {{"machine", machine}};
}

// --- done

TEST_F(JobRunnerTest, DoneItsCommandsAreThePlansMotionsAndItsTimeTheEstimate) {
  start();
  ASSERT_EQ(run(), JobState::done) << reason_;
  EXPECT_EQ(states_, (std::vector<JobState>{JobState::planning, JobState::registering, JobState::probing, JobState::done}));
  const json plan = file(JobFile::plan);
  EXPECT_EQ(plan.at("schema"), "cmmd.plan/2");
  const json& motions = plan.at("motions");
  ASSERT_GT(motions.size(), 100u);

  // Homing, then one command per planned motion, in order, the same to 1e-9 mm.
  const std::vector<RecordedCommand>& sent = recorder_->commands;
  ASSERT_EQ(sent.size(), motions.size() + 1);
  EXPECT_EQ(sent.front().kind, RecordedCommand::Kind::home);
  const auto v = [](const json& j) { return hal::Vec3(j.at(0), j.at(1), j.at(2)); };
  for (std::size_t i = 0; i < motions.size(); ++i) {
    const json& m = motions[i];
    const RecordedCommand& c = sent[i + 1];
    SCOPED_TRACE("motion " + std::to_string(i) + ": " + m.dump());
    if (m.at("kind") == "probe") {
      ASSERT_EQ(c.kind, RecordedCommand::Kind::probe);
      EXPECT_LE((c.probe.start - v(m.at("from"))).norm(), 1e-9);
      EXPECT_LE((c.probe.direction - v(m.at("direction"))).norm(), 1e-9);
      EXPECT_NEAR(c.probe.max_travel_mm, m.at("max_travel_mm").get<double>(), 1e-9);
      EXPECT_NEAR(c.probe.min_travel_mm, m.at("min_travel_mm").get<double>(), 1e-9);
      EXPECT_NEAR(c.probe.retract_mm, m.at("retract_mm").get<double>(), 1e-9);
      EXPECT_NEAR(c.probe.speed_mm_s, m.at("speed_mm_s").get<double>(), 1e-9);
      EXPECT_FALSE(c.probe.fail_on_miss);
    } else {
      ASSERT_EQ(c.kind, RecordedCommand::Kind::move);
      EXPECT_LE((c.move.target - v(m.at("to"))).norm(), 1e-9);
      EXPECT_NEAR(c.move.speed_mm_s, m.at("speed_mm_s").get<double>(), 1e-9);
    }
  }

  // The probing stage (homing and the given registration aside) takes the plan's time to 1 %.
  const double estimate_s = plan.at("estimate").at("time_s");
  const double probing_s = sent.back().t_after_s - sent[1].t_before_s;
  EXPECT_NEAR(probing_s / estimate_s, 1.0, 0.01) << "probing " << probing_s << " s, estimate " << estimate_s << " s";
  const json result = file(JobFile::result);
  EXPECT_NEAR(result.at("probing_time_s").get<double>(), probing_s, 1e-6);
  EXPECT_NEAR(result.at("estimate_s").get<double>(), estimate_s, 1e-9);
  RecordProperty("probing_s", std::to_string(probing_s));
  RecordProperty("estimate_s", std::to_string(estimate_s));

  expect_every_touch_once();
  EXPECT_EQ(contacts_, static_cast<int>(planned_touches()));
  EXPECT_EQ(result.at("registration_method"), "given");
  EXPECT_EQ(file(JobFile::registration).at("tip"), "T1");
  EXPECT_LE((ball() - hal::Vec3(-100, -100, 60)).norm(), 1e-6) << "the program ends home";
  EXPECT_FALSE(link_->touch_in_progress());
}

TEST_F(JobRunnerTest, DoneAgainFromTheJournalWithoutMotionWhenOnlyTheResultWasMissing) {
  start();
  ASSERT_EQ(run(), JobState::done) << reason_;
  std::filesystem::remove(store_->path(id_, JobFile::result));
  const std::size_t commands = recorder_->commands.size();
  ASSERT_EQ(run(), JobState::done) << reason_;
  EXPECT_EQ(recorder_->commands.size(), commands) << "the result was made again with motion";
  EXPECT_NO_THROW(file(JobFile::result));
}

// --- failed

TEST_F(JobRunnerTest, FailedModelNamesTheFile) {
  start({{"model", "file:missing.ply"}});
  EXPECT_EQ(run(), JobState::failed);
  EXPECT_THAT(reason_, HasSubstr("missing.ply"));
  EXPECT_TRUE(recorder_->commands.empty()) << "the machine moved for a job without a model";
}

TEST_F(JobRunnerTest, FailedPlanWhenThePartLeavesNoClearancePlane) {
  // Registered 420 mm higher than it stands: its top in M (z 461) leaves no room for the ball and
  // a gap below the travel box's top (z 450).
  start({{"registration", given_corners(sim_block(), Eigen::Vector3d(0, 0, 420))}});
  EXPECT_EQ(run(), JobState::failed);
  EXPECT_THAT(reason_, HasSubstr("cannot plan the job"));
  EXPECT_THAT(reason_, HasSubstr("clearance plane"));
}

TEST_F(JobRunnerTest, FailedRegistrationNamesTheCorner) {
  json corners = given_corners(sim_block());
  corners["corners"][2]["machine"][0] = corners["corners"][2]["machine"][0].get<double>() + 5;
  start({{"registration", corners}});
  EXPECT_EQ(run(), JobState::failed);
  EXPECT_THAT(reason_, HasSubstr("corner 3"));
  EXPECT_FALSE(store_->read(id_, JobFile::registration));
  EXPECT_TRUE(journal().empty());
}

// --- cancelled

TEST_F(JobRunnerTest, CancelledWhilePlanning) {
  start();
  control_.cancel = true;  // heard by the feature extraction's next step
  runner_->run(false, false);
  EXPECT_EQ(states_.back(), JobState::cancelled);
  EXPECT_EQ(reason_, "cancelled by the operator");
  EXPECT_TRUE(journal().empty());
}

TEST_F(JobRunnerTest, CancelledBetweenTouchesLeavesTheBallOnTheClearancePlane) {
  start();
  after_touch_ = [this](int made) {
    if (made == 5) control_.cancel = true;
  };
  EXPECT_EQ(run(), JobState::cancelled);
  EXPECT_EQ(journal().size(), 5u);
  EXPECT_GE(ball().z(), 60 - 1e-9);
  EXPECT_FALSE(link_->touch_in_progress());
}

TEST_F(JobRunnerTest, CancelledMidTouchLeavesAlongTheSearchLine) {
  start();
  // The cancel comes as touch 8's descent is sent: the touch ends before its probe, and the ball
  // leaves the way it came in.
  int descents = 0;
  recorder_->before = [&](std::size_t i, const RecordedCommand& c) {
    if (descends(i, c) && journal().size() == 7 && ++descents == 1) control_.cancel = true;
  };
  EXPECT_EQ(run(), JobState::cancelled);
  EXPECT_EQ(journal().size(), 7u);
  EXPECT_EQ(recorder_->commands.back().kind, RecordedCommand::Kind::move);
  EXPECT_GE(ball().z(), 60 - 1e-9);
  EXPECT_FALSE(link_->touch_in_progress());
}

// --- paused, and resumed

TEST_F(JobRunnerTest, PausedByTheOperatorResumesWithEveryTouchOnce) {
  start();
  after_touch_ = [this](int made) {
    if (made == 12) control_.pause = true;
  };
  EXPECT_EQ(run(), JobState::paused);
  EXPECT_EQ(reason_, "operator pause");
  EXPECT_EQ(journal().size(), 12u);
  after_touch_ = nullptr;
  EXPECT_EQ(run(), JobState::done) << reason_;
  expect_every_touch_once();
}

TEST_F(JobRunnerTest, PausedByAStopResumesWithEveryTouchOnce) {
  start();
  int descents = 0;
  recorder_->before = [&](std::size_t i, const RecordedCommand& c) {
    if (descends(i, c) && journal().size() == 9 && ++descents == 1)
      control_.operator_stop = true;  // machine.stop as touch 10 descends: the job holds before its probe
  };
  EXPECT_EQ(run(), JobState::paused);
  EXPECT_EQ(reason_, "operator stop");
  EXPECT_EQ(journal().size(), 9u);
  ASSERT_TRUE(link_->touch_in_progress()) << "stopped inside a touch: its line waits for the next mover";
  recorder_->before = nullptr;
  EXPECT_EQ(run(), JobState::done) << reason_;
  expect_every_touch_once();
  EXPECT_FALSE(link_->touch_in_progress());
}

// Once the probe has touched, its result is journalled before the way back to the start: a stop
// flag then waits for the next touch, and a machine that stops on that way (here: the move back
// ends in Aborted) loses nothing: the resume leaves along the search line and does not touch again.
TEST_F(JobRunnerTest, AStopAfterTheProbeKeepsItsTouch) {
  start();
  const auto probes = [this] {
    return std::count_if(recorder_->commands.begin(), recorder_->commands.end(),
                         [](const RecordedCommand& c) { return c.kind == RecordedCommand::Kind::probe; });
  };
  recorder_->before = [&](std::size_t, const RecordedCommand& c) {
    if (c.kind == RecordedCommand::Kind::probe && journal().size() == 9) control_.operator_stop = true;
  };
  EXPECT_EQ(run(), JobState::paused);
  EXPECT_EQ(reason_, "operator stop");
  EXPECT_EQ(journal().size(), 10u) << "the touch the stop came during is kept";
  EXPECT_FALSE(link_->touch_in_progress()) << "its way back was made";

  bool stopped = false;
  recorder_->before = [&](std::size_t i, const RecordedCommand& c) {
    if (!stopped && i > 0 && recorder_->commands[i - 1].kind == RecordedCommand::Kind::probe &&
        c.kind == RecordedCommand::Kind::move && journal().size() == 15) {
      stopped = true;
      throw hal::Aborted("move: stopped by stop()");
    }
  };
  EXPECT_EQ(run(), JobState::paused);
  ASSERT_TRUE(fault_);
  EXPECT_EQ(journal().size(), 15u) << "the touch whose way back was cut is kept";
  EXPECT_TRUE(link_->touch_in_progress());
  recorder_->before = nullptr;
  EXPECT_EQ(run(), JobState::done) << reason_;
  expect_every_touch_once();
  EXPECT_EQ(static_cast<std::size_t>(probes()), planned_touches()) << "a kept touch was made again";
}

TEST_F(JobRunnerTest, PausedByAMachineFaultResumesWithEveryTouchOnce) {
  // A spurious trigger as the simulator's 30th motion starts: an early trigger, not a touch.
  start({}, {{"faults", {{"spurious_trigger_at_motion", 30}}}});
  EXPECT_EQ(run(), JobState::paused);
  ASSERT_TRUE(fault_);
  EXPECT_EQ(fault_->kind, "EarlyTrigger");
  EXPECT_THAT(reason_, HasSubstr("machine fault"));
  EXPECT_EQ(run(), JobState::done) << reason_;
  expect_every_touch_once();
}

// The jobs folder on a small disk of its own (the touch file elsewhere), filled after the sixth
// touch: the journal's last page still takes a few lines, and the touch whose line does not fit is
// made but not journalled. It is kept, and journalled first when the job goes on, not made again.
TEST_F(JobRunnerTest, PausedWhenTheJournalCannotBeWrittenKeepsTheTouch) {
  const std::filesystem::path disk_dir = fresh_folder("runner-disk") / "jobs";
  test::SmallTmpfs disk(disk_dir, 4 << 20);
  if (!disk.mounted()) GTEST_SKIP() << disk.error();
  start({}, {}, disk_dir);
  after_touch_ = [&](int made) {
    if (made == 6) disk.fill();
  };
  const auto probes = [this] {
    return static_cast<std::size_t>(std::count_if(recorder_->commands.begin(), recorder_->commands.end(),
                                                  [](const RecordedCommand& c) { return c.kind == RecordedCommand::Kind::probe; }));
  };
  EXPECT_EQ(run(), JobState::paused);
  ASSERT_TRUE(fault_);
  EXPECT_EQ(fault_->kind, "StorageFull");
  EXPECT_THAT(reason_, HasSubstr("storage full"));
  const std::size_t kept = journal().size();
  EXPECT_GT(kept, 6u);
  EXPECT_EQ(probes(), kept + 1) << "the touch that did not fit was made";
  after_touch_ = nullptr;
  disk.unfill();
  EXPECT_EQ(run(), JobState::done) << reason_;
  expect_every_touch_once();
  EXPECT_EQ(probes(), planned_touches()) << "the kept touch was made again";
}

TEST_F(JobRunnerTest, ATipChangedDuringAHoldIsChangedBackAndAChangedQualificationHolds) {
  start();
  after_touch_ = [this](int made) {
    if (made == 4) control_.pause = true;
  };
  EXPECT_EQ(run(), JobState::paused);
  after_touch_ = nullptr;
  // Someone changed the tip during the hold, clear of the part (T2's ball sits 20 mm below T1's).
  link_->cmm().move({ball() + hal::Vec3(0, 0, 100), 0});
  link_->cmm().select_tip("T2");
  // A qualification the machine now reports that the job's touches were not made under.
  description::TipQualification q;
  q.ball_radius_mm = 0.9991;
  q.time_utc = "2026-12-01T08:00:00Z";
  link_->cmm().record_qualification("T1", q);
  EXPECT_EQ(run(), JobState::paused);
  ASSERT_TRUE(fault_);
  EXPECT_EQ(fault_->kind, "Qualification");
  EXPECT_THAT(reason_, HasSubstr("tip T1's qualification changed"));
  EXPECT_EQ(journal().size(), 4u);
  EXPECT_EQ(link_->cmm().info().active_tip, "T1") << "the job measures with T1 and changed back to it";
  const Recovery recovered = recover_journal(store_->path(id_, JobFile::touches));
  ASSERT_EQ(recovered.tip_changes.size(), 1u);
  EXPECT_EQ(recovered.tip_changes[0].tip, "T1");
}

// --- tips

TEST_F(JobRunnerTest, AnUnqualifiedTipHoldsTheJobBeforeAnyMotion) {
  qualified_.clear();  // a controller that restarted after the operator qualified
  start();
  EXPECT_EQ(run(), JobState::paused);
  ASSERT_TRUE(fault_);
  EXPECT_EQ(fault_->kind, "Qualification");
  EXPECT_THAT(reason_, HasSubstr("tip T1 is not qualified"));
  EXPECT_THAT(reason_, HasSubstr("allow_unqualified_tip"));
  for (const RecordedCommand& c : recorder_->commands) EXPECT_NE(c.kind, RecordedCommand::Kind::probe) << "a touch was made";
  EXPECT_TRUE(journal().empty());
  // The operator qualifies it during the hold: the job goes on with it.
  description::TipQualification q;
  q.ball_radius_mm = 1.0;
  q.time_utc = "2026-12-01T08:00:00Z";
  link_->cmm().record_qualification("T1", q);
  EXPECT_EQ(run(), JobState::done) << reason_;
  EXPECT_EQ(file(JobFile::qualifications)["qualifications"][0]["qualification"]["time_utc"], "2026-12-01T08:00:00Z");
}

TEST_F(JobRunnerTest, AnUnqualifiedTipMeasuresOnlyWhenTheRequestAllowsItAndTheResultSaysSo) {
  qualified_.clear();
  start({{"allow_unqualified_tip", true}, {"tip", "T1"}});
  ASSERT_EQ(run(), JobState::done) << reason_;
  const json result = file(JobFile::result);
  bool said = false;
  for (const json& note : result.at("notes")) said = said || note.get<std::string>().find("nominal tip, not qualified: tip T1") == 0;
  EXPECT_TRUE(said) << result.at("notes").dump(1);
  EXPECT_TRUE(result["traceability"]["tip"]["qualification"].is_null());
  // The report and the QIF say it too.
  const std::string report = *store_->read(id_, JobFile::report), qif = *store_->read(id_, JobFile::result_qif);
  EXPECT_NE(report.find("nominal tip, not qualified: tip T1"), std::string::npos);
  EXPECT_NE(qif.find("<Name>tip T1 (nominal tip, not qualified)</Name>"), std::string::npos);
}

TEST_F(JobRunnerTest, RequalifyQualifiesAnUnqualifiedTipBeforeItsFirstTouch) {
  qualified_.clear();
  start({{"requalify", true}});
  ASSERT_EQ(run(), JobState::done) << reason_;
  const json q = file(JobFile::qualifications)["qualifications"][0];
  EXPECT_EQ(q.at("source"), "qualified by the job (requalify)");
  EXPECT_TRUE(q.at("qualification").is_object());
}

TEST_F(JobRunnerTest, AutoMeasuresTheBoresWithTheLargerQualifiedTipAndSaysWhichTipMadeEachTouch) {
  qualified_ = {"T1", "T2"};
  start();
  ASSERT_EQ(run(), JobState::done) << reason_;
  const json result = file(JobFile::result);
  int bores = 0;
  for (const json& h : result.at("holes")) {
    if (h.at("status") != "measured") continue;
    EXPECT_EQ(h.at("tip"), "T2") << h.dump();
    ++bores;
  }
  EXPECT_GT(bores, 0);
  for (const json& e : result.at("edge_points"))
    if (e.at("status") == "measured" && e.at("tip") != "T1") {
      EXPECT_EQ(e.at("tip"), "T2");
    }
  std::set<std::string> tips;
  for (const json& t : result.at("touch_tips")) tips.insert(t.at("tip").get<std::string>());
  EXPECT_EQ(tips, (std::set<std::string>{"T1", "T2"}));
  // One change to T2 in the program, and the same in the journal.
  int changes = 0;
  const json plan = file(JobFile::plan);
  for (const json& m : plan.at("motions")) changes += m.at("kind") == "change_tip";
  EXPECT_EQ(changes, 1);
  EXPECT_EQ(recover_journal(store_->path(id_, JobFile::touches)).tip_changes.size(), 1u);
  expect_every_touch_once();
}

TEST_F(JobRunnerTest, AMachineWithoutAToolChangerPausesForTheOperatorToFitTheTipAndItsQualification) {
  qualified_ = {"T1", "T2"};
  start(json::object(), without_tool_changer());
  EXPECT_EQ(run(), JobState::paused);
  ASSERT_TRUE(fault_);
  EXPECT_EQ(fault_->kind, "TipChange");
  EXPECT_THAT(reason_, HasSubstr("fit tip T2"));
  const std::size_t made = journal().size();
  EXPECT_GT(made, 0u);
  // Resumed without qualifying the fitted tip: it holds for the qualification.
  EXPECT_EQ(run(), JobState::paused);
  EXPECT_EQ(fault_->kind, "Qualification");
  EXPECT_THAT(reason_, HasSubstr("tip T2 was fitted by hand"));
  EXPECT_EQ(journal().size(), made);
  description::TipQualification q;
  q.ball_radius_mm = 2.5;
  q.offset = link_->cmm().info().find_tip("T2")->offset;
  q.time_utc = "2099-01-01T00:00:00Z";  // made after the change was asked for
  link_->cmm().record_qualification("T2", q);
  EXPECT_EQ(run(), JobState::done) << reason_;
  expect_every_touch_once();
}

// --- interrupted

TEST_F(JobRunnerTest, InterruptedByShutdownResumesAfterRehoming) {
  start();
  after_touch_ = [this](int made) {
    if (made == 3) control_.shutdown = true;
  };
  EXPECT_EQ(run(), JobState::interrupted);
  EXPECT_EQ(reason_, "cmmd stopped during the job");
  after_touch_ = nullptr;
  const std::size_t before = recorder_->commands.size();
  EXPECT_EQ(run(true), JobState::done) << reason_;
  EXPECT_EQ(recorder_->commands[before].kind, RecordedCommand::Kind::home) << "an interrupted job homes first";
  expect_every_touch_once();
}

// --- the stored reference mesh

TEST_F(JobRunnerTest, TheMeshPlannedOnIsStoredWithWhereItCameFrom) {
  start();
  ASSERT_EQ(run(), JobState::done) << reason_;
  const geometry::TriangleMesh stored = geometry::read_mesh(store_->path(id_, JobFile::reference_mesh));
  const geometry::TriangleMesh model = geometry::read_mesh(dir_ / "models" / "part.ply");
  EXPECT_EQ(stored.vertices, model.vertices);
  EXPECT_EQ(stored.faces, model.faces);
  const json info = file(JobFile::reference_info);
  EXPECT_EQ(info.at("mesh"), "reference.ply");
  EXPECT_EQ(info.at("model"), "file:part.ply");
  EXPECT_EQ(info.at("model_file"), std::filesystem::canonical(dir_ / "models" / "part.ply").string());
  EXPECT_EQ(info.at("scan"), nullptr) << "a mesh model is no scan";
  EXPECT_EQ(info.at("sha256"), sha256_hex_of_file(store_->path(id_, JobFile::reference_mesh)));
  const json from_plan = file(JobFile::plan).at("model").at("reference_mesh");
  EXPECT_EQ(from_plan.at("planned_on"), "model");
  EXPECT_EQ(from_plan.at("sha256"), info.at("sha256"));
  EXPECT_EQ(file(JobFile::result).at("traceability").at("reference_mesh").at("planned_on"), "model");
}

// The model file is replaced by another part (scaled by 1.2) while the job is interrupted: the
// resumed job plans on the mesh it stored, so the plan it makes again (reregister drops plan.json and
// writes it anew) is the first plan, edge point for edge point and touch for touch.
TEST_F(JobRunnerTest, AResumedJobPlansOnItsStoredMeshNotOnAChangedModelFile) {
  start();
  after_touch_ = [this](int made) {
    if (made == 3) control_.shutdown = true;
  };
  ASSERT_EQ(run(), JobState::interrupted);
  after_touch_ = nullptr;
  const json first = file(JobFile::plan);
  geometry::TriangleMesh other = geometry::make_case3_block(2).mesh;
  other.vertices *= 1.2;
  geometry::write_mesh(dir_ / "models" / "part.ply", other);

  ASSERT_EQ(run(true, true), JobState::done) << reason_;
  const json again = file(JobFile::plan);
  EXPECT_EQ(again.at("model").at("reference_mesh").at("planned_on"), "stored_mesh");
  EXPECT_EQ(again.at("model").at("scale"), 1);
  EXPECT_EQ(again.at("model").at("file"), store_->path(id_, JobFile::reference_mesh).string());
  ASSERT_EQ(again.at("edge_points").size(), first.at("edge_points").size());
  EXPECT_EQ(again.at("edge_points"), first.at("edge_points"));
  EXPECT_EQ(again.at("holes"), first.at("holes"));
  EXPECT_EQ(again.at("program"), first.at("program"));
  EXPECT_EQ(again.at("motions"), first.at("motions"));
  expect_every_touch_once();
  const json trace = file(JobFile::result).at("traceability").at("reference_mesh");
  EXPECT_EQ(trace.at("planned_on"), "stored_mesh");
  EXPECT_EQ(trace.at("model"), "file:part.ply");

  // And the changed file would have given another plan: a new job on it plans other edge points.
  const JobReference fresh = job_reference(*store_, store_->create(json::object(), "other", "file:part.ply").id,
                                           *models_, *request_, config_->description.travel_box);
  EXPECT_EQ(fresh.provenance.at("planned_on"), "model");
  EXPECT_NE(fresh.model.mesh.vertices, geometry::read_mesh(store_->path(id_, JobFile::reference_mesh)).vertices);
}

TEST_F(JobRunnerTest, AResumeWithoutTheModelFileStillPlans) {
  start();
  after_touch_ = [this](int made) {
    if (made == 2) control_.pause = true;
  };
  ASSERT_EQ(run(), JobState::paused);
  after_touch_ = nullptr;
  std::filesystem::remove(dir_ / "models" / "part.ply");
  ASSERT_EQ(run(), JobState::done) << reason_;
  expect_every_touch_once();
}

TEST_F(JobRunnerTest, AResumeRefusesAStoredMeshThatChanged) {
  start();
  after_touch_ = [this](int made) {
    if (made == 2) control_.pause = true;
  };
  ASSERT_EQ(run(), JobState::paused);
  after_touch_ = nullptr;
  std::string bytes = *store_->read(id_, JobFile::reference_mesh);
  bytes[bytes.size() - 5] ^= 1;  // a bit of the last face's corner index
  store_->write(id_, JobFile::reference_mesh, bytes);
  EXPECT_EQ(run(), JobState::failed);
  EXPECT_THAT(reason_, HasSubstr("stored reference mesh " + store_->path(id_, JobFile::reference_mesh).string() +
                                 " hashes to"));
  EXPECT_THAT(reason_, HasSubstr("not the mesh the job was planned on"));
  EXPECT_EQ(journal().size(), 2u) << "no touch on a mesh that is not the plan's";
}

// A raw scan's mesh is stored as well, and a resumed job takes its features as from the scan again:
// judged by its vertex scatter alone, the stored mesh of a noise-free scan counts as clean (sides from
// the single facets at the edge) where the scan's own counts as noisy, and the edge points would move.
TEST_F(JobRunnerTest, AScansStoredMeshGivesTheSameEdgePointsAgain) {
  start({{"model", "file:scan.xyz"}, {"tolerance_mm", 0.1}});
  sim::RawScanOptions scan;
  scan.spacing_mm = 0.8;
  scan.noise_sigma_mm = 0;
  geometry::write_cloud(dir_ / "models" / "scan.xyz", sim::synthesize_raw_scan(geometry::make_case3_block(1).mesh, scan).cloud);
  const int id = store_->create(json::object(), "scan", request_->model).id;
  const JobReference first = job_reference(*store_, id, *models_, *request_, config_->description.travel_box);
  const JobReference again = job_reference(*store_, id, *models_, *request_, config_->description.travel_box);
  ASSERT_TRUE(first.model.scan.has_value());
  EXPECT_EQ(again.provenance.at("planned_on"), "stored_mesh");
  EXPECT_TRUE(again.model.features.features.noisy);
  ASSERT_EQ(again.model.features.points.size(), first.model.features.points.size());
  for (std::size_t i = 0; i < first.model.features.points.size(); ++i) {
    const geometry::EdgePoint &a = first.model.features.points[i], &b = again.model.features.points[i];
    EXPECT_EQ(a.position, b.position) << "point " << i;
    EXPECT_EQ(a.n_up, b.n_up) << "point " << i;
    EXPECT_EQ(a.probeable, b.probeable) << "point " << i;
  }
}

}  // namespace
}  // namespace cmm::daemon
