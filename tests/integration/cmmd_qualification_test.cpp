// A controller that restarts mid-job forgets its tip qualification (docs/api.md, jobs): a real cmmd
// drives a real cmm-sim over Modbus, the tip qualified first; cmm-sim is killed mid-probing and
// started again on the same port. The job must not go on with the tip's nominal values: it pauses
// for requalification (or, asked to, requalifies itself), and the result, held against the
// simulator's true part, keeps every edge within 10 µm. The simulated tip's true offset is 20 µm
// off its nominal, so a touch made with the nominal offset is visibly off the true edge.
#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "job_watch.hpp"
#include "scratch_folder.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/true_edge_distance.hpp"
#include "sim/sim_config.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::CmmdInstance;

constexpr double wait_s = 120;
constexpr double wall_time_scale = 100;  // a kill lands mid-probing; the rest runs in no wall time

struct Scratch : testing::ScratchFolder {
  explicit Scratch(const std::string& name) : ScratchFolder("cmmd_qualification_test", name) {}
};

// The sample machine, its tip T1 off its nominal offset by 20 µm: what only a qualification finds.
const json offset_error = {0.012, -0.010, 0.013};

json sim_block() {
  json block = testing::sample_sim_block();
  block["true_tips"] = {{"T1", {{"offset_error", offset_error}}}};
  return block;
}

geometry::Vec3 vec(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()}; }

// Notifications until `match`; the job ending first is a failure that says how.
json await_job(daemon::RpcClient& watch, int job, const std::string& what, const testing::NotificationMatch& match) {
  return testing::await_job(watch, job, what, match, wait_s, testing::job_ended);
}

// The result against the simulator's true part: every measured edge point within 10 µm of a true
// edge, every bore's centre within 10 µm of the true axis; the figures printed.
void expect_on_the_truth(const json& result, const std::string& what) {
  const sim::SimConfig truth = sim::sim_config_from_json(sim_block());
  const geometry::AnalyticPart part = geometry::make_analytic_part("case3_block", 0.25);
  const Eigen::Isometry3d T_Part_M = (truth.T_M_P * truth.T_P_Part).inverse();
  double sum2 = 0, worst = 0;
  int edges = 0, over = 0;
  for (const json& e : result.at("edge_points")) {
    if (e.at("status") != "measured") continue;
    const double d = geometry::nearest_true_edge(part, T_Part_M * vec(e["measured_M"]["position"])).distance;
    sum2 += d * d, worst = std::max(worst, d), ++edges, over += d > 0.01;
  }
  double worst_centre = 0;
  int bores = 0;
  for (const json& h : result.at("holes")) {
    if (h.at("status") != "measured") continue;
    const geometry::Vec3 c = T_Part_M * vec(h["measured_M"]["centre"]);
    double best = 1e9;
    for (const geometry::TrueHole& t : part.holes) {
      const geometry::Vec3 v = c - t.centre;
      best = std::min(best, (v - v.dot(t.axis) * t.axis).norm());
    }
    worst_centre = std::max(worst_centre, best), ++bores;
  }
  std::printf("%s: %d edge points vs the true edges: RMS %.4f mm, max %.4f mm, %d over 0.010 mm; %d bores, centre off "
              "the axis max %.4f mm\n",
              what.c_str(), edges, edges ? std::sqrt(sum2 / edges) : 0.0, worst, over, bores, worst_centre);
  EXPECT_GT(edges, 50);
  EXPECT_EQ(over, 0) << over << " edge points more than 10 µm off the true edge (worst " << worst << " mm)";
  EXPECT_GT(bores, 0);
  EXPECT_LT(worst_centre, 0.01);
}

// cmm-sim and a cmmd driving it over Modbus, the tip qualified, a job probing: the controller is
// killed mid-probing (the job pauses, CommLost) and started again on the same port, where it knows
// its tips' nominal values only.
struct RestartedController {
  explicit RestartedController(const std::string& name, bool requalify)
      : dir(name), config(dir.path / "sim.json"),
        sim(std::make_unique<testing::SimulatorProcess>(write_config(config), wall_time_scale)),
        cmmd(dir.path / "cmmd", testing::modbus_block(sim->port),
             {{"machine_description", CMMD_SOURCE_DIR "/config/machine.json"}}) {
    const auto scan = testing::sample_scan(dir.path / "scan");
    cmmd.start();
    client.emplace(cmmd.client());
    watch.emplace(cmmd.client());
    watch->call("server.subscribe", {{"topics", {"job"}}});
    first = client->call("machine.qualify", json::object(), wait_s);
    // The qualification finds the true offset, 20 µm off the nominal.
    EXPECT_LT((vec(first.at("offset")) - vec(offset_error)).norm(), 0.002) << first.dump();
    json request = {{"registration", testing::sample_measure_plate(dir.path / "scan")}, {"seed", 1}, {"spacing_mm", 10}};
    request["requalify"] = requalify;
    id = testing::submit_job(*client, scan, request);
    folder = cmmd.job_folder(id);
    total = await_job(*watch, id, "probing", testing::job_progress_at_least(id, "probing", 0))["params"]["total"];
    await_job(*watch, id, "a quarter of the touches", testing::job_progress_at_least(id, "probing", total / 4));
    const int port = sim->port;
    sim->process.signal(SIGKILL);
    sim->process.wait();
    sim.reset();
    await_job(*watch, id, "the pause for the lost link", testing::job_state_is(id, "paused"));
    const json paused = client->call("job.get", {{"job", id}});
    EXPECT_EQ(paused.at("fault").value("kind", ""), "CommLost") << paused.dump();
    before = testing::journal_touch_ids(folder).size();
    std::printf("cmm-sim killed after %zu of %d touches\n", before, total);
    // Back on the same port, motion in no wall time: it has forgotten the qualification.
    sim = std::make_unique<testing::SimulatorProcess>(config, 0, port);
  }

  static const std::filesystem::path& write_config(const std::filesystem::path& file) {
    std::filesystem::create_directories(file.parent_path());
    std::ofstream(file) << sim_block().dump(1) << "\n";
    return file;
  }

  // The qualifications the result says its touches were made under.
  void expect_two_qualifications(const json& result, const std::string& second_source, const json& second) {
    const json& tip = result.at("traceability").at("tip");
    EXPECT_EQ(tip.at("id"), "T1");
    ASSERT_EQ(tip.at("qualifications").size(), 2u) << tip.dump(1);
    const json& q0 = tip["qualifications"][0];
    const json& q1 = tip["qualifications"][1];
    EXPECT_EQ(tip.at("qualification").at("time_utc"), first.at("time_utc")) << tip.dump(1);
    EXPECT_EQ(q0.at("qualification").at("time_utc"), first.at("time_utc"));
    EXPECT_EQ(q0.at("job_touches"), before) << "the touches before the restart are not the first qualification's";
    EXPECT_EQ(q1.at("source"), second_source);
    ASSERT_TRUE(q1.at("qualification").is_object()) << "touches were made with the tip unqualified: " << q1.dump();
    EXPECT_EQ(q1.at("job_touches").get<int>(), total - static_cast<int>(before));
    EXPECT_NEAR(q1.at("ball_radius_mm").get<double>(), first.at("ball_radius_mm").get<double>(), 0.002);
    EXPECT_LT((vec(q1.at("offset")) - vec(first.at("offset"))).norm(), 0.002) << "not the tip's true offset";
    if (second.is_object()) {
      EXPECT_EQ(q1["qualification"].at("time_utc"), second.at("time_utc"));
    }
    EXPECT_EQ(result.at("probe").at("ball_radius_mm"), q0.at("ball_radius_mm"));
    EXPECT_NEAR(q1.at("radius_adjustment_mm").get<double>(),
                q1.at("ball_radius_mm").get<double>() - q0.at("ball_radius_mm").get<double>(), 1e-12);
  }

  Scratch dir;
  std::filesystem::path config;
  std::unique_ptr<testing::SimulatorProcess> sim;
  CmmdInstance cmmd;
  std::optional<daemon::RpcClient> client, watch;
  json first;  // machine.qualify's answer before the job
  int id = 0, total = 0;
  std::filesystem::path folder;
  std::size_t before = 0;  // touches made before the controller restarted
};

TEST(CmmdQualification, AJobWhoseTipLostItsQualificationPausesForItAndFinishesOnTheTrueEdgesAfterMachineQualify) {
  RestartedController c("operator", false);
  c.client->call("job.resume", {{"job", c.id}});
  await_job(*c.watch, c.id, "the pause for the qualification", testing::job_state_is(c.id, "paused"));
  const json held = c.client->call("job.get", {{"job", c.id}});
  EXPECT_EQ(held.at("reason").get<std::string>().rfind("tip T1's qualification vanished since the job began: qualify it", 0), 0u)
      << held.dump();
  EXPECT_EQ(held.at("fault").value("kind", ""), "Qualification") << held.dump();
  EXPECT_EQ(testing::journal_touch_ids(c.folder).size(), c.before) << "a touch was made with the tip unqualified";
  // Resumed without qualifying: it holds again; nothing is made with the nominal tip.
  c.client->call("job.resume", {{"job", c.id}});
  await_job(*c.watch, c.id, "the pause again", testing::job_state_is(c.id, "paused"));
  EXPECT_EQ(c.client->call("job.get", {{"job", c.id}}).at("reason"), held.at("reason"));
  EXPECT_EQ(testing::journal_touch_ids(c.folder).size(), c.before);

  // The job let the machine go before it announced the hold: the operator's qualify is not busy.
  const json second = c.client->call("machine.qualify", json::object(), wait_s);
  c.client->call("job.resume", {{"job", c.id}});
  testing::wait_for_job(*c.client, c.id, {"done"}, wait_s);
  const json result = c.client->call("job.result", {{"job", c.id}});
  c.expect_two_qualifications(result, "machine.qualify while the job was held", second);
  expect_on_the_truth(result, "qualified again by the operator");
  EXPECT_EQ(c.cmmd.terminate(), 0);
}

TEST(CmmdQualification, AJobThatAsksToRequalifyQualifiesTheTipItselfAndFinishesOnTheTrueEdges) {
  RestartedController c("requalify", true);
  c.client->call("job.resume", {{"job", c.id}});
  testing::wait_for_job(*c.client, c.id, {"done"}, wait_s);
  const json result = c.client->call("job.result", {{"job", c.id}});
  c.expect_two_qualifications(result, "qualified by the job (requalify)", nullptr);
  expect_on_the_truth(result, "qualified again by the job");
  EXPECT_EQ(c.cmmd.terminate(), 0);
}

TEST(CmmdQualification, RequalifyIsTrueOrFalseAndKeptWithTheRequest) {
  const Scratch dir("request");
  const auto scan = testing::sample_scan(dir.path / "scan");
  CmmdInstance cmmd(dir.path / "cmmd", testing::sample_sim_block());
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  const json request = {{"registration", testing::sample_measure_plate(dir.path / "scan")}};
  try {
    json bad = request;
    bad["requalify"] = "yes";
    testing::submit_job(client, scan, bad);
    FAIL() << "requalify \"yes\" was taken";
  } catch (const daemon::RpcError& e) {
    EXPECT_EQ(e.code(), -32602) << e.what();
    EXPECT_EQ(e.data().value("path", ""), "/requalify") << e.data().dump();
  }
  EXPECT_TRUE(client.call("job.list").at("jobs").empty());
  json good = request;
  good["requalify"] = true;
  const int id = testing::submit_job(client, scan, good);
  client.call("job.cancel", {{"job", id}});
  EXPECT_EQ(testing::read_json_file(cmmd.job_folder(id) / "request.json").at("requalify"), true);
  json unsaid = request;
  unsaid["allow_unqualified_tip"] = false;  // the helper would otherwise ask for requalify
  const int plain = testing::submit_job(client, scan, unsaid);
  client.call("job.cancel", {{"job", plain}});
  EXPECT_EQ(testing::read_json_file(cmmd.job_folder(plain) / "request.json").at("requalify"), false) << "the default is not stored";
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
