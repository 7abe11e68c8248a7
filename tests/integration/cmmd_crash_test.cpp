// Crash safety and job control of cmmd (docs/api.md, jobs; DESIGN.md, Files): cmmd SIGKILLed at
// seeded moments of one job, cmm-sim killed or frozen mid-move, a torn journal line, pause, stop and
// cancel.
#include <gtest/gtest.h>
#include <modbus/modbus.h>

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <future>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "job_watch.hpp"
#include "scratch_folder.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/touch_journal.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/true_edge_distance.hpp"
#include "hal/modbus_map.hpp"
#include "sim/sim_config.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::CmmdInstance;

// Where the kills land; printed, so that a failing run can be replayed.
constexpr std::uint32_t kill_seed = 20261124;
constexpr double wait_s = 120;
// Motion in wall time / 100: a kill, stop or cancel lands inside a move, and a job (about a second
// of machine time per touch) still takes seconds.
constexpr double wall_time_scale = 100;

struct Scratch : testing::ScratchFolder {
  explicit Scratch(const std::string& name) : ScratchFolder("cmmd_crash_test", name) {}
};

// cmmd.json's machine description for a cmm-sim over Modbus.
json machine_description() { return {{"machine_description", CMMD_SOURCE_DIR "/config/machine.json"}}; }

int uniform(std::mt19937& rng, int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); }

geometry::Vec3 vec(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()}; }

double clearance_of(const std::filesystem::path& job_folder) {
  return testing::read_json_file(job_folder / "plan.json").at("clearance_z").get<double>();
}

// The journal after a kill or a hold: the program's first touches, each once, none skipped.
void expect_program_prefix(const std::vector<int>& journal, const std::vector<int>& program, const std::string& when) {
  ASSERT_LE(journal.size(), program.size()) << when;
  const auto differ = std::mismatch(journal.begin(), journal.end(), program.begin());
  EXPECT_EQ(differ.first, journal.end())
      << "touches.jsonl " << when << " has touch " << *differ.first << " where the program has " << *differ.second
      << " (line " << (differ.first - journal.begin() + 1) << ")";
}

// What a finished job left.
struct Finished {
  json result;
  std::vector<int> journal, program;
  bool torn_tail = false;
  std::set<int> edge_ids, measured_edges, measured_holes;
};

Finished finished(daemon::RpcClient& client, const std::filesystem::path& job_folder, int job) {
  Finished f;
  f.result = client.call("job.result", {{"job", job}});
  for (const json& e : f.result.at("edge_points")) {
    const int id = e.at("id").get<int>();
    if (!f.edge_ids.insert(id).second) ADD_FAILURE() << "edge point " << id << " is in result.json twice";
    if (e.at("status") == "measured") f.measured_edges.insert(id);
  }
  for (const json& h : f.result.at("holes"))
    if (h.at("status") == "measured") f.measured_holes.insert(h.at("id").get<int>());
  f.journal = testing::journal_touch_ids(job_folder);
  f.torn_tail = daemon::recover_journal(job_folder / "touches.jsonl").torn_tail;
  f.program = testing::program_order(job_folder);
  return f;
}

// Every planned touch made exactly once, in program order, and the result built on all of them.
void expect_every_touch_once(const Finished& f) {
  EXPECT_EQ(f.journal, f.program) << "touches.jsonl does not hold the program's touches, each once";
  EXPECT_FALSE(f.torn_tail) << "touches.jsonl ends in a torn line";
  EXPECT_EQ(f.result.at("touches").get<std::size_t>(), f.program.size());
}

void expect_same_points(const Finished& got, const Finished& uninterrupted) {
  EXPECT_EQ(got.edge_ids, uninterrupted.edge_ids) << "the result's edge points differ from the uninterrupted run's";
  EXPECT_EQ(got.measured_edges, uninterrupted.measured_edges)
      << "the measured edge points differ from the uninterrupted run's";
  EXPECT_EQ(got.measured_holes, uninterrupted.measured_holes)
      << "the measured holes differ from the uninterrupted run's";
}

// Every measured edge point within 10 µm of the simulated part's true edge.
void expect_on_the_true_edges(const json& result) {
  const sim::SimConfig truth = sim::sim_config_from_json(testing::sample_sim_block());
  const geometry::AnalyticPart part = geometry::make_analytic_part("case3_block", 0.25);
  const Eigen::Isometry3d T_Part_M = (truth.T_M_P * truth.T_P_Part).inverse();
  for (const json& e : result.at("edge_points")) {
    if (e.at("status") != "measured") continue;
    const double d = geometry::nearest_true_edge(part, T_Part_M * vec(e["measured_M"]["position"])).distance;
    EXPECT_LT(d, 0.01) << "edge point " << e["id"] << " is " << d << " mm off the true edge";
  }
}

// The job run once, start to end, over Modbus on a cmm-sim of the sample part whose motion takes
// no wall time.
Finished uninterrupted(const std::filesystem::path& folder, const std::filesystem::path& scan, const json& request) {
  testing::SimulatorProcess sim(scan.parent_path() / "sim.json", 0);
  CmmdInstance cmmd(folder, testing::modbus_block(sim.port), machine_description());
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  const int id = testing::submit_job(client, scan, request);
  testing::wait_for_job(client, id, {"done"}, wait_s);
  Finished f = finished(client, cmmd.job_folder(id), id);
  expect_every_touch_once(f);
  EXPECT_EQ(cmmd.terminate(), 0);
  return f;
}

// Notifications until `match`; the job ending or holding first is a failure that says why.
json await_job(daemon::RpcClient& watch, int job, const std::string& what, const testing::NotificationMatch& match) {
  return testing::await_job(watch, job, what, match, wait_s, testing::job_ended_or_held);
}

int total_of(const json& progress) { return progress.at("params").at("total").get<int>(); }

// Asks machine.status until the ball moves below the clearance plane: inside a touch, not between.
json await_moving_below(daemon::RpcClient& client, double clearance_z) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
  for (;;) {
    const json s = client.call("machine.status");
    if (s.value("moving", false) && s.at("position").at(2).get<double>() < clearance_z - 0.5) return s;
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("the ball never moved below the clearance plane: " + s.dump());
  }
}

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A cmmd on one folder that can be SIGKILLed and started again; `watch` hears the job topic.
class Cmmd {
 public:
  Cmmd(std::filesystem::path folder, json machine, json extra = json::object())
      : cmmd_(std::move(folder), std::move(machine), std::move(extra)) {}

  void start() {
    cmmd_.start();
    watch_.emplace(cmmd_.client());
    watch_->call("server.subscribe", {{"topics", {"job"}}});
    client_.emplace(cmmd_.client());
  }
  void kill() {
    watch_.reset();
    client_.reset();
    cmmd_.kill9();
  }
  // After a kill: cmmd starts again on the same folder, the job is interrupted from `during`, and
  // job.resume lets it go on.
  void restart_and_resume(int job, const std::string& during) {
    start();
    const json record = client().call("job.get", {{"job", job}});
    EXPECT_EQ(record.at("state"), "interrupted") << record.dump();
    EXPECT_EQ(record.at("reason"), "cmmd restarted during " + during) << record.dump();
    client().call("job.resume", {{"job", job}});
  }
  int terminate() { return cmmd_.terminate(); }

  // <state>/touch_in_progress.json: a touch entered and not yet left (docs/api.md). Written by
  // rename, so it is whole or absent, even as the running job leaves the touch.
  std::optional<json> touch_in_progress() const {
    std::ifstream in(cmmd_.folder() / "state" / "touch_in_progress.json");
    if (!in) return std::nullopt;
    return json::parse(in);
  }
  json status() { return client().call("machine.status"); }
  daemon::RpcClient connect() const { return cmmd_.client(); }  // one more client, e.g. for another thread

  daemon::RpcClient& watch() { return *watch_; }
  daemon::RpcClient& client() { return *client_; }
  std::filesystem::path job_folder(int job) const { return cmmd_.job_folder(job); }

 private:
  CmmdInstance cmmd_;
  std::optional<daemon::RpcClient> watch_, client_;
};

// Which touch of the program a touch_in_progress.json belongs to (by its search line: a bore's
// touches share their start), or -1.
// The touch a stop cut short is the first one missing from touches.jsonl, or, when the stop came on
// its way back to the start, the last one kept there: a touch is journalled as soon as it has touched.
bool cut_short_touch_fits_the_journal(int cut_short, std::size_t journalled) {
  const int made = static_cast<int>(journalled);
  return cut_short == made || cut_short == made - 1;
}

int program_index(const std::filesystem::path& job_folder, const json& touch_file) {
  const json program = testing::read_json_file(job_folder / "plan.json").at("program");
  const auto on = [&](const json& touch, const char* key) {
    return (vec(touch.at(key)) - vec(touch_file.at(key))).norm() < 1e-6;
  };
  for (std::size_t i = 0; i < program.size(); ++i)
    if (on(program[i], "start") && on(program[i], "direction")) return static_cast<int>(i);
  return -1;
}

// Waits until the ball moves inside a touch; returns that touch's touch_in_progress.json (see
// program_index, for after whatever must come at once).
json await_mid_touch(Cmmd& d, int job) {
  const double clearance_z = clearance_of(d.job_folder(job));
  for (;;) {
    await_moving_below(d.client(), clearance_z);
    if (std::optional<json> t = d.touch_in_progress()) return *t;
  }
}

// SIGKILL while the ball moves inside a touch: touch_in_progress.json is still there after the kill.
// A kill that came just after the touch ended is resumed from, and the next touch tried once the
// job probes again: before that the resumed run homes and leaves the old touch while planning, and a
// kill there is a kill during planning.
void kill_mid_touch(Cmmd& d, int job) {
  const double clearance_z = clearance_of(d.job_folder(job));
  for (int attempt = 1;; ++attempt) {
    const json s = await_moving_below(d.client(), clearance_z);
    d.kill();
    if (d.touch_in_progress()) {
      std::printf("killed mid-touch, the ball at z = %.3f\n", s["position"][2].get<double>());
      return;
    }
    if (attempt == 5) throw std::runtime_error("5 kills all came between touches");
    d.restart_and_resume(job, "probing");
    await_job(d.watch(), job, "probing after the resume", testing::job_state_is(job, "probing"));
  }
}

TEST(CmmdCrash, KilledAtSeededMomentsOfOneJobItResumesToTheUninterruptedResult) {
  const Scratch dir("kill9");
  const auto scan = testing::sample_scan(dir.path / "scan");
  const json request = testing::spaced_job_request(dir.path / "scan");
  const Finished baseline = uninterrupted(dir.path / "baseline", scan, request);
  ASSERT_FALSE(baseline.measured_edges.empty());

  std::mt19937 rng(kill_seed);
  std::printf("kill seed %u\n", kill_seed);
  // One cmm-sim throughout: the machine outlives each cmmd that drives it, as a real one does, and
  // a restarted cmmd finds it where the killed one left it.
  testing::SimulatorProcess sim(dir.path / "scan" / "sim.json", wall_time_scale);
  Cmmd d(dir.path / "crashing", testing::modbus_block(sim.port), machine_description());
  d.start();
  const int id = testing::submit_job(d.client(), scan, request);
  const std::filesystem::path folder = d.job_folder(id);
  int kills = 0;

  await_job(d.watch(), id, "planning", testing::job_state_is(id, "planning"));
  d.kill();
  ++kills;
  std::printf("killed while planning\n");
  d.restart_and_resume(id, "planning");

  // A plate touch's progress is reported as it starts: the kill lands in that touch.
  const int plate_touches = total_of(await_job(d.watch(), id, "registering", testing::job_progress_at_least(id, "registering", 0)));
  const int plate_at = uniform(rng, 1, plate_touches - 1);
  await_job(d.watch(), id, "plate touch " + std::to_string(plate_at), testing::job_progress_at_least(id, "registering", plate_at));
  d.kill();
  ++kills;
  std::printf("killed in plate touch %d of %d\n", plate_at, plate_touches);
  EXPECT_FALSE(std::filesystem::exists(folder / "registration.json")) << "a half-measured registration was kept";
  d.restart_and_resume(id, "registering");

  // Probing: right after a touch and inside one, in turn, at seeded touch counts.
  const int total = total_of(await_job(d.watch(), id, "probing", testing::job_progress_at_least(id, "probing", 0)));
  const std::vector<int> program = testing::program_order(folder);
  ASSERT_EQ(static_cast<int>(program.size()), total);
  const std::string registration = read_text(folder / "registration.json");
  for (int i = 0; i < 4; ++i) {
    const int at = uniform(rng, total * i / 5 + 1, total * (i + 1) / 5);
    if (i % 2 == 0) {
      await_job(d.watch(), id, "touch " + std::to_string(at), testing::job_progress_at_least(id, "probing", at - 1));
      const int touch = await_job(d.watch(), id, "a job.touch", testing::job_touched(id))["params"]["touch"];
      d.kill();
      std::printf("killed right after touch %d (about %d of %d)\n", touch, at, total);
      const std::vector<int> journal = testing::journal_touch_ids(folder);
      EXPECT_NE(std::find(journal.begin(), journal.end(), touch), journal.end())
          << "touch " << touch << " was notified but is not in touches.jsonl";
    } else {
      await_job(d.watch(), id, "touch " + std::to_string(at), testing::job_progress_at_least(id, "probing", at));
      kill_mid_touch(d, id);
      const std::size_t made = testing::journal_touch_ids(folder).size();
      EXPECT_TRUE(cut_short_touch_fits_the_journal(program_index(folder, *d.touch_in_progress()), made))
          << "the touch cut short (" << program_index(folder, *d.touch_in_progress()) << ") is neither the first one missing from "
          << "touches.jsonl nor the last one kept (" << made << " kept)";
    }
    ++kills;
    const std::vector<int> journal = testing::journal_touch_ids(folder);
    expect_program_prefix(journal, program, "after kill " + std::to_string(kills));
    d.restart_and_resume(id, "probing");
    const int next = await_job(d.watch(), id, "the first touch after the resume", testing::job_touched(id))["params"]["touch"];
    EXPECT_EQ(next, program.at(journal.size()))
        << "the resumed job did not go on from the first touch not in the journal";
  }
  testing::wait_for_job(d.client(), id, {"done"}, wait_s);
  EXPECT_GE(kills, 5);
  EXPECT_EQ(read_text(folder / "registration.json"), registration) << "a resume changed the registration";
  const Finished f = finished(d.client(), folder, id);
  expect_every_touch_once(f);
  expect_same_points(f, baseline);
  expect_on_the_true_edges(f.result);
  EXPECT_EQ(d.terminate(), 0);
}

TEST(CmmdCrash, CmmSimKilledMidMovePausesTheJobWithCommLostAndResumeOnTheSamePortFinishesIt) {
  const Scratch dir("simkill");
  const auto scan = testing::sample_scan(dir.path / "scan");
  const json request = testing::spaced_job_request(dir.path / "scan");
  const std::filesystem::path sim_config = dir.path / "scan" / "sim.json";
  std::mt19937 rng(kill_seed);
  std::printf("kill seed %u\n", kill_seed);
  auto sim = std::make_unique<testing::SimulatorProcess>(sim_config, wall_time_scale);
  const int port = sim->port;  // the port cmmd keeps reconnecting to, where cmm-sim comes back
  Cmmd d(dir.path / "cmmd", testing::modbus_block(port), machine_description());
  d.start();
  const int id = testing::submit_job(d.client(), scan, request);
  const int total = total_of(await_job(d.watch(), id, "probing", testing::job_progress_at_least(id, "probing", 0)));
  const int at = uniform(rng, total / 10, total / 4);
  await_job(d.watch(), id, "touch " + std::to_string(at), testing::job_progress_at_least(id, "probing", at));
  const json s = await_moving_below(d.client(), clearance_of(d.job_folder(id)));
  sim->process.signal(SIGKILL);
  sim->process.wait();
  sim.reset();
  std::printf("killed cmm-sim moving, after %d of %d touches, the ball at z = %.3f\n", at, total,
              s["position"][2].get<double>());

  await_job(d.watch(), id, "paused", testing::job_state_is(id, "paused"));
  const json paused = d.client().call("job.get", {{"job", id}});
  ASSERT_TRUE(paused.at("fault").is_object()) << paused.dump();
  EXPECT_EQ(paused["fault"].at("kind"), "CommLost") << paused.dump();
  EXPECT_TRUE(d.touch_in_progress()) << "the touch the link loss cut short is not recorded";
  expect_program_prefix(testing::journal_touch_ids(d.job_folder(id)), testing::program_order(d.job_folder(id)),
                        "after the link loss");

  // The same port, motion in no wall time: the rest of the job takes no longer than it must.
  sim = std::make_unique<testing::SimulatorProcess>(sim_config, 0, port);
  ASSERT_EQ(sim->port, port);
  d.client().call("job.resume", {{"job", id}});
  testing::wait_for_job(d.client(), id, {"done"}, wait_s);
  const Finished f = finished(d.client(), d.job_folder(id), id);
  expect_every_touch_once(f);
  expect_on_the_true_edges(f.result);
  EXPECT_EQ(d.terminate(), 0);
}

// Where cmm-sim's ball is, read from the machine itself over a Modbus connection of the test's own.
geometry::Vec3 sim_position(int port) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  std::uint16_t r[hal::modbus::kStatusCount] = {};
  const bool read = modbus_connect(ctx) == 0 &&
                    modbus_read_registers(ctx, hal::modbus::kStatusFirst, hal::modbus::kStatusCount, r) ==
                        hal::modbus::kStatusCount;
  modbus_close(ctx);
  modbus_free(ctx);
  if (!read) throw std::runtime_error("cannot read cmm-sim's status on port " + std::to_string(port));
  const std::uint16_t* p = r + hal::modbus::address("position_x");
  return geometry::Vec3(hal::modbus::get_i32(p), hal::modbus::get_i32(p + 2), hal::modbus::get_i32(p + 4)) * 1e-6;
}

// From a resume until the ball is back on the clearance plane (after that the next touch's own ways
// in, which the plan checked; the touch cut short is not always made again, as a touch kept on its way
// back is done) or the job makes its next touch, machine.status sampled as fast as cmmd answers:
// every position below the clearance plane lies on the search line of the touch that was cut short
// (a retract longer than the travel to the trigger ends just behind its start), or straight above its
// start (the ways in and out the plan checked), or straight above where the ball stood at the pause
// when that was not between the start and the part (it came down that way, or is just behind the
// start). A ball that rose straight from inside the touch, or went anywhere else first, is caught if
// a sample lands there.
void expect_leaves_along_the_search_line(Cmmd& d, int job, const json& touch_file, const geometry::Vec3& paused_at) {
  const double clearance_z = clearance_of(d.job_folder(job));
  const geometry::Vec3 start = vec(touch_file.at("start")), direction = vec(touch_file.at("direction"));
  const auto off_line = [](const geometry::Vec3& p, const geometry::Vec3& from, const geometry::Vec3& dir) {
    const geometry::Vec3 v = p - from;
    return (v - v.dot(dir) * dir).norm();
  };
  const auto off_ray = [&](const geometry::Vec3& p, const geometry::Vec3& from, const geometry::Vec3& dir) {
    return (p - from).dot(dir) < 0 ? (p - from).norm() : off_line(p, from, dir);
  };
  const geometry::Vec3 up = geometry::Vec3::UnitZ();
  const bool paused_off = off_ray(paused_at, start, direction) > 1e-3 && off_ray(paused_at, start, up) > 1e-3;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
  int samples = 0;
  for (;;) {
    if (const std::optional<json> n = d.watch().wait_notification(0)) {
      if (testing::job_touched(job)(*n)) break;
      const json& p = n->at("params");
      if (n->at("method") == "job.state" && p.at("job") == job && p.at("state") != "planning" &&
          p.at("state") != "registering" && p.at("state") != "probing")
        FAIL() << "the resumed job became " << p.at("state") << " (" << p.value("reason", "") << ") before a touch";
    }
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "no touch after the resume";
    const json s = d.status();
    if (!s.contains("position")) continue;  // the link is not up yet
    const geometry::Vec3 at = vec(s["position"]);
    if (at.z() > clearance_z - 1e-3) {
      if (samples > 0) break;  // it has left the touch
      continue;
    }
    ++samples;
    const double off = std::min({off_line(at, start, direction), off_ray(at, start, up),
                                 paused_off ? off_ray(at, paused_at, up) : HUGE_VAL});
    ASSERT_LT(off, 1e-3) << "after the resume the ball was at (" << at.transpose() << "), off the search line from ("
                         << start.transpose() << ") along (" << direction.transpose()
                         << ") and not straight above its start; it stopped at (" << paused_at.transpose() << ")";
  }
  std::printf("%d positions below the clearance plane sampled on the way out and in again\n", samples);
}

// cmm-sim frozen (SIGSTOP) inside a touch for longer than the driver's response timeout and its own
// heartbeat watch, then let go (SIGCONT), twice: the job pauses with Timeout each time. The first time
// machine.reset reconnects, leaves the touch and resets before job.resume; the second time job.resume
// reconnects itself and leaves the touch along its search line. The answers the frozen machine still
// owed arrive late and are never read as answers to later requests; every planned touch is made once.
TEST(CmmdCrash, CmmSimFrozenMidTouchPausesTheJobWithTimeoutAndResetAndResumeFinishIt) {
  const Scratch dir("simfreeze");
  const auto scan = testing::sample_scan(dir.path / "scan");
  std::mt19937 rng(kill_seed);
  std::printf("kill seed %u\n", kill_seed);
  testing::SimulatorProcess sim(dir.path / "scan" / "sim.json", wall_time_scale);
  // Short timeouts keep the test quick: the driver gives up on an answer after 0.5 s, the machine
  // brakes when the heartbeat is 1 s old; the freeze outlasts both.
  json machine = testing::modbus_block(sim.port);
  machine.update({{"response_timeout_s", 0.5}, {"heartbeat_s", 0.1}, {"heartbeat_timeout_s", 1}});
  constexpr auto freeze = std::chrono::milliseconds(1500);
  Cmmd d(dir.path / "cmmd", machine, machine_description());
  d.start();
  const int id = testing::submit_job(d.client(), scan, testing::spaced_job_request(dir.path / "scan"));
  const std::filesystem::path folder = d.job_folder(id);
  const int total = total_of(await_job(d.watch(), id, "probing", testing::job_progress_at_least(id, "probing", 0)));
  const std::vector<int> program = testing::program_order(folder);
  for (const bool reset_first : {true, false}) {
    const int at = uniform(rng, total * (reset_first ? 1 : 3) / 5 + 1, total * (reset_first ? 2 : 4) / 5);
    await_job(d.watch(), id, "touch " + std::to_string(at), testing::job_progress_at_least(id, "probing", at));
    const json s = await_moving_below(d.client(), clearance_of(folder));
    sim.process.signal(SIGSTOP);
    const auto frozen = std::chrono::steady_clock::now();
    std::printf("froze cmm-sim after %d of %d touches, the ball moving at z = %.3f\n", at, total,
                s["position"][2].get<double>());
    await_job(d.watch(), id, "paused", testing::job_state_is(id, "paused"));  // the driver gives up while it is frozen
    std::this_thread::sleep_until(frozen + freeze);
    sim.process.signal(SIGCONT);

    const json paused = d.client().call("job.get", {{"job", id}});
    ASSERT_TRUE(paused.at("fault").is_object()) << paused.dump();
    EXPECT_EQ(paused["fault"].at("kind"), "Timeout") << paused.dump();
    const std::optional<json> touch_file = d.touch_in_progress();
    ASSERT_TRUE(touch_file) << "the touch the freeze cut short is not recorded";
    const std::vector<int> journal = testing::journal_touch_ids(folder);
    expect_program_prefix(journal, program, "after the freeze");
    EXPECT_TRUE(cut_short_touch_fits_the_journal(program_index(folder, *touch_file), journal.size()))
        << "the touch cut short (" << program_index(folder, *touch_file) << ") is neither the first one missing from "
        << "touches.jsonl nor the last one kept (" << journal.size() << " kept)";

    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the heartbeat's brake, in machine time
    const geometry::Vec3 paused_at = sim_position(sim.port);
    if (reset_first) {
      try {
        d.client().call("machine.reset", json::object(), wait_s);
        EXPECT_FALSE(d.touch_in_progress()) << "machine.reset did not take the ball out of the touch first";
        EXPECT_EQ(d.status().at("link"), "up");
      } catch (const daemon::RpcError& e) {
        ADD_FAILURE() << "machine.reset after the freeze: " << e.what() << " " << e.data().dump();
      }
      d.client().call("job.resume", {{"job", id}});
    } else {
      d.client().call("job.resume", {{"job", id}});
      expect_leaves_along_the_search_line(d, id, *touch_file, paused_at);
    }
    if (::testing::Test::HasFatalFailure()) return;
  }
  const json record = testing::wait_for_job(d.client(), id, {"done", "paused"}, wait_s);
  ASSERT_EQ(record.at("state"), "done") << record.dump();
  const Finished f = finished(d.client(), folder, id);
  expect_every_touch_once(f);
  expect_on_the_true_edges(f.result);
  EXPECT_EQ(d.terminate(), 0);
}

TEST(CmmdCrash, AJournalLineTornByTheCrashIsIgnoredAndItsTouchMadeAgainOnce) {
  const Scratch dir("journal");
  const auto scan = testing::sample_scan(dir.path / "scan");
  std::mt19937 rng(kill_seed);
  std::printf("kill seed %u\n", kill_seed);
  testing::SimulatorProcess sim(dir.path / "scan" / "sim.json", wall_time_scale);
  Cmmd d(dir.path / "cmmd", testing::modbus_block(sim.port), machine_description());
  d.start();
  const int id = testing::submit_job(d.client(), scan, testing::spaced_job_request(dir.path / "scan"));
  const std::filesystem::path folder = d.job_folder(id), journal = folder / "touches.jsonl";
  const int total = total_of(await_job(d.watch(), id, "probing", testing::job_progress_at_least(id, "probing", 0)));
  const std::vector<int> program = testing::program_order(folder);
  // Half a line, as a crash inside the write leaves it; then no line, as a crash just before it.
  for (const bool torn : {true, false}) {
    const int at = uniform(rng, total * (torn ? 1 : 3) / 5 + 1, total * (torn ? 2 : 4) / 5);
    await_job(d.watch(), id, "touch " + std::to_string(at), testing::job_progress_at_least(id, "probing", at - 1));
    await_job(d.watch(), id, "a job.touch", testing::job_touched(id));
    d.kill();
    const std::string text = read_text(journal);
    ASSERT_GE(text.size(), 2u);
    const std::size_t last = text.rfind('\n', text.size() - 2) + 1;  // npos + 1 = 0: a one-line journal
    const int lost = json::parse(text.substr(last)).at("touch");
    std::filesystem::resize_file(journal, torn ? last + (text.size() - last) / 2 : last);
    std::printf("touches.jsonl's last line (touch %d) %s\n", lost, torn ? "cut in half" : "removed");
    ASSERT_EQ(daemon::recover_journal(journal).torn_tail, torn);
    const std::vector<int> left = testing::journal_touch_ids(folder);
    expect_program_prefix(left, program, "with its last line lost");
    d.restart_and_resume(id, "probing");
    const int next = await_job(d.watch(), id, "the first touch after the resume", testing::job_touched(id))["params"]["touch"];
    EXPECT_EQ(next, lost) << "the touch whose line was lost is not the first one made again";
  }
  testing::wait_for_job(d.client(), id, {"done"}, wait_s);
  expect_every_touch_once(finished(d.client(), folder, id));
  EXPECT_EQ(d.terminate(), 0);
}

// A job on a fresh cmmd driving the in-process simulator in wall time, probing, past a seeded
// touch count between a tenth and a quarter of its program.
struct ProbingJob {
  explicit ProbingJob(const std::string& name) : dir(name), d(dir.path / "cmmd", testing::timed_sim_block(wall_time_scale)) {
    const auto scan = testing::sample_scan(dir.path / "scan");
    d.start();
    id = testing::submit_job(d.client(), scan, testing::spaced_job_request(dir.path / "scan"));
    folder = d.job_folder(id);
    total = total_of(await_job(d.watch(), id, "probing", testing::job_progress_at_least(id, "probing", 0)));
    program = testing::program_order(folder);
    await_touches(total / 10, total / 4);
  }
  // Until the job has made a seeded number of touches in [lo, hi].
  void await_touches(int lo, int hi) {
    await_job(d.watch(), id, "probing", testing::job_progress_at_least(id, "probing", uniform(rng, lo, hi)));
  }

  Scratch dir;
  Cmmd d;
  std::mt19937 rng{kill_seed};
  int id = 0, total = 0;
  std::filesystem::path folder;
  std::vector<int> program;
};

TEST(CmmdJobControl, PauseMidTouchHoldsAfterItAStopMidTouchPausesAndResumeMakesEveryTouchOnce) {
  ProbingJob job("pause");
  Cmmd& d = job.d;
  const int id = job.id;
  const std::filesystem::path& folder = job.folder;
  const json paused_touch = await_mid_touch(d, id);
  d.client().call("job.pause", {{"job", id}});
  // Once job.pause has replied no touch may begin: one in progress now is the last.
  const std::optional<json> last_touch = d.touch_in_progress();
  const int paused_in = program_index(folder, paused_touch);
  ASSERT_GE(paused_in, 0) << "touch_in_progress.json is no touch of the plan: " << paused_touch.dump();
  await_job(d.watch(), id, "paused", testing::job_state_is(id, "paused"));
  json record = d.client().call("job.get", {{"job", id}});
  EXPECT_EQ(record.at("reason"), "operator pause") << record.dump();
  EXPECT_TRUE(record.at("fault").is_null()) << record.dump();
  EXPECT_FALSE(d.status().at("moving").get<bool>());
  EXPECT_FALSE(d.touch_in_progress()) << "the pause cut a touch short";
  std::vector<int> journal = testing::journal_touch_ids(folder);
  expect_program_prefix(journal, job.program, "after the pause");
  EXPECT_GE(static_cast<int>(journal.size()), paused_in + 1) << "the touch the pause came in was not finished";
  if (last_touch) {
    EXPECT_EQ(static_cast<int>(journal.size()), program_index(folder, *last_touch) + 1)
        << "the job went on after the touch in progress";
  }
  d.client().call("job.resume", {{"job", id}});

  job.await_touches(job.total / 2, 3 * job.total / 4);
  for (int attempt = 1;; ++attempt) {
    await_mid_touch(d, id);
    d.client().call("machine.stop");
    await_job(d.watch(), id, "paused", testing::job_state_is(id, "paused"));
    record = d.client().call("job.get", {{"job", id}});
    EXPECT_EQ(record.at("reason"), "operator stop") << record.dump();
    EXPECT_FALSE(d.status().at("moving").get<bool>());
    if (d.touch_in_progress()) break;  // the stop cut a touch short, as meant
    ASSERT_LT(attempt, 5) << "5 stops all came between touches";
    d.client().call("job.resume", {{"job", id}});
    await_job(d.watch(), id, "probing after the resume", testing::job_state_is(id, "probing"));  // not the planning's moves
  }
  journal = testing::journal_touch_ids(folder);
  expect_program_prefix(journal, job.program, "after the stop");
  EXPECT_TRUE(cut_short_touch_fits_the_journal(program_index(folder, *d.touch_in_progress()), journal.size()))
        << "the touch the stop cut short is neither the first one missing from touches.jsonl nor the last one kept";
  d.client().call("job.resume", {{"job", id}});

  testing::wait_for_job(d.client(), id, {"done"}, wait_s);
  expect_every_touch_once(finished(d.client(), folder, id));
  EXPECT_EQ(d.terminate(), 0);
}

// A cancelled job ends with the ball still, on or above the clearance plane, no touch left open.
void expect_cancelled_clear_of_the_part(Cmmd& d, int job) {
  await_job(d.watch(), job, "cancelled", testing::job_state_is(job, "cancelled"));
  const json record = d.client().call("job.get", {{"job", job}});
  EXPECT_EQ(record.at("reason"), "cancelled by the operator") << record.dump();
  const json s = d.status();
  EXPECT_FALSE(s.at("moving").get<bool>()) << s.dump();
  EXPECT_GE(s.at("position").at(2).get<double>(), clearance_of(d.job_folder(job)) - 1e-3)
      << "the cancelled job left the ball below the clearance plane: " << s.dump();
  EXPECT_FALSE(d.touch_in_progress()) << "the cancelled job left a touch open";
  expect_program_prefix(testing::journal_touch_ids(d.job_folder(job)), testing::program_order(d.job_folder(job)),
                        "after the cancel");
}

TEST(CmmdJobControl, CancelMidTouchLeavesTheBallOnTheClearancePlane) {
  ProbingJob job("cancel_touch");
  await_mid_touch(job.d, job.id);
  job.d.client().call("job.cancel", {{"job", job.id}});
  expect_cancelled_clear_of_the_part(job.d, job.id);
  EXPECT_EQ(job.d.terminate(), 0);
}

// Between touches the ball rests at the last touch's search start, below the plane. A resumed job
// plans again before its next touch: a cancel then finds it there, running and between touches.
TEST(CmmdJobControl, CancelBetweenTouchesLeavesTheBallOnTheClearancePlane) {
  ProbingJob job("cancel_between");
  Cmmd& d = job.d;
  const int id = job.id;
  const std::filesystem::path& folder = job.folder;
  d.client().call("job.pause", {{"job", id}});
  await_job(d.watch(), id, "paused", testing::job_state_is(id, "paused"));
  const json held = d.status();
  ASSERT_LT(held.at("position").at(2).get<double>(), clearance_of(folder) - 1) << "nothing to prove: " << held.dump();
  const std::size_t made = testing::journal_touch_ids(folder).size();

  d.client().call("job.resume", {{"job", id}});
  await_job(d.watch(), id, "planning", testing::job_state_is(id, "planning"));
  d.client().call("job.cancel", {{"job", id}});
  expect_cancelled_clear_of_the_part(d, id);
  EXPECT_EQ(testing::journal_touch_ids(folder).size(), made) << "the cancel came after the next touch began";
  EXPECT_EQ(d.terminate(), 0);
}

// machine.stop ends a qualification in progress with Aborted, whether it meets one of its motions
// or comes between two (the motion after is not started); a stop that came before the next
// qualification does not end that one.
TEST(CmmdJobControl, AStopEndsAQualificationInProgressAndTheNextOneRuns) {
  const Scratch dir("qualify_stop");
  Cmmd d(dir.path / "cmmd", testing::timed_sim_block(20));  // a qualification takes about two seconds
  d.start();
  d.client().call("machine.home", json::object(), wait_s);
  auto qualifying = std::async(std::launch::async, [&d] {
    daemon::RpcClient client = d.connect();
    try {
      return client.call("machine.qualify", json::object(), wait_s);
    } catch (const daemon::RpcError& e) {
      return json{{"code", e.code()}, {"message", e.what()}, {"data", e.data()}};
    }
  });
  while (!d.status().value("moving", false))
    ASSERT_NE(qualifying.wait_for(std::chrono::seconds(0)), std::future_status::ready)
        << "the qualification ended before it was seen moving: " << qualifying.get().dump();
  d.client().call("machine.stop");
  const json stopped = qualifying.get();
  EXPECT_EQ(stopped.value("code", 0), daemon::rpc_code::machine_fault) << stopped.dump();
  EXPECT_EQ(stopped.value("data", json::object()).value("kind", ""), "Aborted") << stopped.dump();
  EXPECT_FALSE(d.status().at("moving").get<bool>());

  const json q = d.client().call("machine.qualify", json::object(), wait_s);
  EXPECT_EQ(q.at("touches"), 9) << q.dump();
  EXPECT_EQ(d.terminate(), 0);
}

}  // namespace
}  // namespace cmm
