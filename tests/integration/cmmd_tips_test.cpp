// Tips a job measures with, on a real cmmd driving a real cmm-sim over Modbus: a controller that
// restarts between the submit and the start forgets its qualification, and the job makes no touch
// with the nominal tip (it holds, or qualifies the tip itself when asked); and with both of the
// sample machine's tips qualified, one job measures the edges with T1 and the bores with T2 (its
// longer shaft reaches down the 41 mm bores), each touch naming its tip, all held against the
// simulator's true part. The simulated tips are off their nominal radius and offset, so a touch made
// with the nominal values shows in the truth.
#include <gtest/gtest.h>

#include <signal.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "job_watch.hpp"
#include "scratch_folder.hpp"
#include "daemon/client/model_upload.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/true_edge_distance.hpp"
#include "sim/sim_config.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::CmmdInstance;

constexpr double wait_s = 300;

struct Scratch : testing::ScratchFolder {
  explicit Scratch(const std::string& name) : ScratchFolder("cmmd_tips_test", name) {}
};

// The sample part, its tips as config/samples/demo_sim.json has them: each off its nominal.
json sim_block() {
  json block = testing::sample_sim_block();
  // The result is held against the analytic part: facets of 0.1 mm keep the simulator's bore walls
  // within 0.3 µm of the true circles (0.25 mm facets sit up to 1.6 µm inside a Ø10 bore).
  block["part"]["edge_length_mm"] = 0.1;
  block["true_tips"] = {{"T1", {{"ball_radius_mm", 0.9985}, {"offset_error", {0.004, -0.003, 0.002}}}},
                        {"T2", {{"ball_radius_mm", 2.4962}, {"offset_error", {-0.006, 0.005, -0.009}}}}};
  return block;
}

geometry::Vec3 vec(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()}; }

const std::filesystem::path& write_config(const std::filesystem::path& file) {
  std::filesystem::create_directories(file.parent_path());
  std::ofstream(file) << sim_block().dump(1) << "\n";
  return file;
}

// cmm-sim at full speed and a cmmd driving it over Modbus with the sample machine description.
struct Station {
  explicit Station(const std::string& name)
      : dir(name), config(write_config(dir.path / "sim.json")),
        sim(std::make_unique<testing::SimulatorProcess>(config, 0)),
        cmmd(dir.path / "cmmd", testing::modbus_block(sim->port),
             {{"machine_description", CMMD_SOURCE_DIR "/config/machine.json"}}),
        scan(testing::sample_scan(dir.path / "scan")) {
    cmmd.start();
    client.emplace(cmmd.client());
  }
  // The controller restarts on the same port: it knows its tips' nominal values only.
  void restart_controller() {
    const int port = sim->port;
    sim->process.signal(SIGKILL);
    sim->process.wait();
    sim.reset();
    sim = std::make_unique<testing::SimulatorProcess>(config, 0, port);
  }
  int submit(json request) {
    request["registration"] = testing::sample_measure_plate(dir.path / "scan");
    request["seed"] = 1;
    return testing::submit_job(*client, scan, request);
  }

  Scratch dir;
  std::filesystem::path config;
  std::unique_ptr<testing::SimulatorProcess> sim;
  CmmdInstance cmmd;
  std::filesystem::path scan;
  std::optional<daemon::RpcClient> client;
};

// The job's state once it settles in one of `states` (a reconnect may pass through others first).
json settled(daemon::RpcClient& client, int job, const std::set<std::string>& states) {
  return testing::wait_for_job(client, job, states, wait_s);
}

TEST(CmmdTips, AControllerThatRestartedBeforeTheJobStartedHoldsItBeforeAnyTouchUntilTheTipIsQualified) {
  Station s("restart-before-start");
  s.client->call("machine.qualify", json::object(), wait_s);
  s.restart_controller();
  // The link comes back with the tip's nominal values: the status says the tip is not qualified.
  const int id = s.submit({{"spacing_mm", 10}, {"tip", "T1"}, {"requalify", false}});
  const json held = settled(*s.client, id, {"paused", "done", "failed"});
  ASSERT_EQ(held.at("state"), "paused") << held.dump(1);
  EXPECT_EQ(held.at("fault").value("kind", ""), "Qualification") << held.dump(1);
  EXPECT_NE(held.at("reason").get<std::string>().find("tip T1 is not qualified"), std::string::npos) << held.dump(1);
  EXPECT_TRUE(testing::journal_touch_ids(s.cmmd.job_folder(id)).empty()) << "a touch was made with the nominal tip";
  const json status = s.client->call("machine.status");
  ASSERT_TRUE(status.at("tips").is_array()) << status.dump(1);
  for (const json& t : status["tips"]) {
    if (t.at("id") != "T1") continue;
    EXPECT_FALSE(t.at("qualified").get<bool>()) << t.dump();
  }

  const json second = s.client->call("machine.qualify", {{"tip", "T1"}}, wait_s);
  s.client->call("job.resume", {{"job", id}});
  // The record says paused until the worker takes the resume up: only done ends the wait.
  ASSERT_EQ(settled(*s.client, id, {"done"}).at("state"), "done");
  const json result = s.client->call("job.result", {{"job", id}});
  const json& q = result.at("traceability").at("tip").at("qualifications");
  ASSERT_EQ(q.size(), 1u) << q.dump(1);
  EXPECT_EQ(q[0].at("qualification").at("time_utc"), second.at("time_utc")) << "not the qualification made after the restart";
  EXPECT_EQ(s.cmmd.terminate(), 0);
}

TEST(CmmdTips, AJobThatMayRequalifyQualifiesTheForgottenTipItselfBeforeItsFirstTouch) {
  Station s("restart-requalify");
  s.restart_controller();  // never qualified since the controller started
  const int id = s.submit({{"spacing_mm", 10}, {"tip", "T1"}, {"requalify", true}});
  ASSERT_EQ(settled(*s.client, id, {"done", "failed", "paused"}).at("state"), "done");
  const json result = s.client->call("job.result", {{"job", id}});
  const json& q = result.at("traceability").at("tip").at("qualifications");
  ASSERT_EQ(q.size(), 1u) << q.dump(1);
  EXPECT_EQ(q[0].at("source"), "qualified by the job (requalify)");
  EXPECT_TRUE(q[0].at("qualification").is_object());
  EXPECT_EQ(s.cmmd.terminate(), 0);
}

// The sample part with the default tips, both qualified: the edges with T1, every bore with T2.
TEST(CmmdTips, TheSamplePartsBoresAreMeasuredWithT2AndItsEdgesWithT1OnTheTrueEdges) {
  Station s("bores-with-t2");
  s.client->call("machine.qualify", {{"tip", "T1"}}, wait_s);
  s.client->call("machine.qualify", {{"tip", "T2"}}, wait_s);
  // The preview plans and dry-runs the same tips, changing to T2 on the way, with no fault.
  const json preview = s.client->call("plan.preview", {{"model", daemon::upload_model(*s.client, s.scan)},
                                                       {"registration", testing::sample_measure_plate(s.dir.path / "scan")},
                                                       {"spacing_mm", 4}},
                                      wait_s);
  EXPECT_EQ(preview.at("tips"), json({"T1", "T2"})) << preview.dump(1);
  EXPECT_EQ(preview.at("dry_run").at("early_triggers"), 0) << preview.dump(1);
  EXPECT_EQ(preview.at("dry_run").at("other_faults"), 0) << preview.dump(1);
  const int id = s.submit({{"spacing_mm", 4}});
  ASSERT_EQ(settled(*s.client, id, {"done", "failed", "paused"}).at("state"), "done");
  const json result = s.client->call("job.result", {{"job", id}});

  const sim::SimConfig truth = sim::sim_config_from_json(sim_block());
  const geometry::AnalyticPart part = geometry::make_analytic_part("case3_block", 0.25);
  const Eigen::Isometry3d T_Part_M = (truth.T_M_P * truth.T_P_Part).inverse();
  double sum2 = 0, worst = 0;
  int edges = 0;
  for (const json& e : result.at("edge_points")) {
    if (e.at("status") != "measured") continue;
    EXPECT_TRUE(e.at("tip") == "T1" || e.at("tip") == "T2") << e.dump();
    const double d = geometry::nearest_true_edge(part, T_Part_M * vec(e["measured_M"]["position"])).distance;
    sum2 += d * d, worst = std::max(worst, d), ++edges;
  }
  // Each true bore measured once, with T2, its diameter against the truth.
  std::map<int, double> diameter_error;  // by true hole
  for (const json& h : result.at("holes")) {
    if (h.at("status") != "measured") continue;
    EXPECT_EQ(h.at("tip"), "T2") << h.dump();
    const geometry::Vec3 c = T_Part_M * vec(h["measured_M"]["centre"]);
    for (std::size_t k = 0; k < part.holes.size(); ++k) {
      const geometry::Vec3 v = c - part.holes[k].centre;
      if ((v - v.dot(part.holes[k].axis) * part.holes[k].axis).norm() < 0.05)
        diameter_error[static_cast<int>(k)] = h.at("diameter_mm").get<double>() - 2 * part.holes[k].radius;
    }
  }
  double worst_diameter = 0;
  for (const auto& [hole, error] : diameter_error) {
    std::printf("true bore %d (Ø%.0f): diameter error %+.4f mm\n", hole, 2 * part.holes[static_cast<std::size_t>(hole)].radius, error);
    worst_diameter = std::max(worst_diameter, std::abs(error));
  }
  const double rms = edges ? std::sqrt(sum2 / edges) : 0;
  std::printf("T1 and T2: %d edge points vs the true edges: RMS %.4f mm, max %.4f mm; %zu of %zu true bores measured with "
              "T2, diameter error max %.4f mm\n",
              edges, rms, worst, diameter_error.size(), part.holes.size(), worst_diameter);
  EXPECT_GT(edges, 100);
  EXPECT_LE(rms, 0.003);
  EXPECT_EQ(diameter_error.size(), part.holes.size()) << "not every bore of the part was measured";
  EXPECT_LE(worst_diameter, 0.005);
  // cmm-truth, as an operator would hold the result against the simulator's part, says the same.
  const std::filesystem::path result_file = s.dir.path / "result.json", truth_file = s.dir.path / "truth.json";
  std::ofstream(result_file) << result.dump() << "\n";
  const auto truth_run = cmm::test::run_command(std::string(CMMD_BINARY_DIR "/sim/cmm-truth --config ") + s.config.string() +
                                                " " + result_file.string() + " --json " + truth_file.string());
  ASSERT_EQ(truth_run.exit_code, 0) << truth_run.output;
  std::printf("cmm-truth: %s", truth_run.output.c_str());
  const json figures = testing::read_json_file(truth_file);
  EXPECT_LE(figures.at("edges").at("rms_mm").get<double>(), 0.003) << figures.dump();
  EXPECT_EQ(figures.at("holes").at("count"), 5) << figures.dump();
  EXPECT_LE(figures.at("holes").at("diameter_max_mm").get<double>(), 0.005) << figures.dump();

  // Each touch names its tip and the qualification it was made under; each tip's qualification is
  // the one machine.qualify measured.
  std::set<std::string> tips;
  const json& qualifications = result.at("traceability").at("tip").at("qualifications");
  for (const json& t : result.at("touch_tips")) {
    tips.insert(t.at("tip").get<std::string>());
    const json& q = qualifications.at(t.at("q").get<std::size_t>());
    EXPECT_EQ(q.at("tip"), t.at("tip")) << t.dump();
    EXPECT_TRUE(q.at("qualification").is_object()) << q.dump();
  }
  EXPECT_EQ(tips, (std::set<std::string>{"T1", "T2"}));
  EXPECT_EQ(s.cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
