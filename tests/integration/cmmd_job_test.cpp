// cmmd end to end: the real daemon driving cmm-sim over Modbus TCP and over I++ DME, jobs submitted
// over its Unix socket; the measured edges and bores are held against the simulator's true part.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "cmmd_instance.hpp"
#include "job_watch.hpp"
#include "daemon/client/model_upload.hpp"
#include "daemon/client/rpc_error.hpp"
#include "geometry/analytic_parts.hpp"
#include "geometry/true_edge_distance.hpp"
#include "sim/sim_config.hpp"

namespace cmm {
namespace {

using nlohmann::json;
using testing::CmmdInstance;
using testing::modbus_block;
using testing::SimulatorProcess;

std::filesystem::path scratch(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("cmmd_job_test_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

geometry::Vec3 vec(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()}; }

// The whole job on the sample part: qualify, register on the plate, measure every planned edge
// point and bore, and hold each against the true part.
void measure_the_sample_part(const std::filesystem::path& dir, const json& machine_block) {
  const auto scan = testing::sample_scan(dir / "scan");
  CmmdInstance cmmd(dir / "cmmd", machine_block, {{"machine_description", CMMD_SOURCE_DIR "/config/machine.json"}});
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  const json q = client.call("machine.qualify", json::object(), 300);
  EXPECT_NEAR(q.at("ball_radius_mm").get<double>(), 0.9985, 0.003) << q.dump();

  const int id = testing::submit_job(client, scan, {{"registration", testing::sample_measure_plate(dir / "scan")}});
  const json record = testing::wait_for_job(client, id, {"done"}, 900);
  const json result = client.call("job.result", {{"job", id}});

  const sim::SimConfig truth = sim::sim_config_from_json(testing::sample_sim_block());
  const geometry::AnalyticPart part = geometry::make_analytic_part("case3_block", 0.25);
  const Eigen::Isometry3d T_Part_M = (truth.T_M_P * truth.T_P_Part).inverse();
  int measured = 0;
  double worst = 0;
  for (const json& e : result.at("edge_points")) {
    if (e.at("status") != "measured") continue;
    ++measured;
    const double d = geometry::nearest_true_edge(part, T_Part_M * vec(e["measured_M"]["position"])).distance;
    worst = std::max(worst, d);
    EXPECT_LT(d, 0.01) << "edge point " << e["id"] << " (" << e["method"] << ") is " << d << " mm off the true edge";
  }
  const int total = result["summary"]["edge_points"]["total"].get<int>();
  // Every planned point is measured; the rest (the open boundary where the scan lost the bottom,
  // edges too low or too close for the stylus) are not planned, each with its reason.
  EXPECT_EQ(result["summary"]["edge_points"]["failed"].get<int>(), 0) << result["summary"].dump();
  EXPECT_GE(measured, 300) << result["summary"].dump();
  std::printf("measured %d of %d edge points, worst %.4f mm from the true edge\n", measured, total, worst);

  int bores = 0;
  for (const json& h : result.at("holes")) {
    if (h.at("status") != "measured") continue;
    ++bores;
    const geometry::Vec3 c = T_Part_M * vec(h["measured_M"]["centre"]);
    double best = 1e9, diameter_error = 0;
    for (const geometry::TrueHole& t : part.holes) {
      const geometry::Vec3 v = c - t.centre;
      const double off = (v - v.dot(t.axis) * t.axis).norm();
      if (off < best) {
        best = off;
        diameter_error = h["diameter_mm"].get<double>() - 2 * t.radius;
      }
    }
    EXPECT_LT(best, 0.01) << "hole " << h["id"];
    EXPECT_LT(std::abs(diameter_error), 0.01) << "hole " << h["id"];
  }
  // Of the five through holes the four Ø10 are bored; the Ø42 one is 41 mm deep, deeper than the
  // 20 mm stylus reaches, and the plan says so instead of touching it.
  EXPECT_EQ(bores, 4);

  // Registration was measured, not given, and the residual is small.
  EXPECT_EQ(result.at("registration_method"), "measured");
  EXPECT_LT(result["registration"]["rms_mm"].get<double>(), 0.05);
  // Traceability: who made it, from what.
  const json& t = result.at("traceability");
  EXPECT_FALSE(t.at("cmmd_version").get<std::string>().empty());
  EXPECT_EQ(t.at("config_sha256").get<std::string>().size(), 64u);
  EXPECT_EQ(t.at("tip").at("id"), "T1");
  EXPECT_FALSE(t["tip"]["qualification"].is_null());
  // The CSV has one row per edge point under its header.
  const std::string csv = client.call("job.result", {{"job", id}, {"format", "csv"}}).at("csv");
  EXPECT_EQ(static_cast<int>(std::count(csv.begin(), csv.end(), '\n')), total + 1);
  EXPECT_TRUE(std::filesystem::exists(cmmd.job_folder(id) / "merged.ply"));
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(CmmdJob, MeasuresThePlateAndEveryEdgeOverModbusWithinTenMicrometresOfTheTruth) {
  const auto dir = scratch("full");
  testing::sample_scan(dir / "scan");
  SimulatorProcess sim(dir / "scan" / "sim.json", 100);
  measure_the_sample_part(dir, modbus_block(sim.port));
}

// The same job through a commercial controller's interface: cmmd's I++ DME client against
// cmm-sim's I++ server, to the same truth.
TEST(CmmdJob, MeasuresThePlateAndEveryEdgeOverIppDmeWithinTenMicrometresOfTheTruth) {
  const auto dir = scratch("ippdme");
  testing::sample_scan(dir / "scan");
  SimulatorProcess sim(dir / "scan" / "sim.json", 100, 0, {"--ippdme", "0"});
  measure_the_sample_part(dir, testing::ippdme_block(sim.ippdme_port));
}

TEST(CmmdJob, PreviewDryRunsTheProgramOnTheReferenceMesh) {
  const auto dir = scratch("preview");
  const auto scan = testing::sample_scan(dir / "scan");
  CmmdInstance cmmd(dir / "cmmd", testing::sample_sim_block());
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  json params = {{"model", daemon::upload_model(client, scan)},
                 {"registration", testing::sample_measure_plate(dir / "scan")}};
  const json preview = client.call("plan.preview", params, 600);
  EXPECT_GT(preview["touches"].get<int>(), 100);
  EXPECT_EQ(preview["dry_run"]["touches"], preview["touches"]);
  // Planned on the reference mesh and run against it, every touch finds its surface.
  EXPECT_EQ(preview["dry_run"]["early_triggers"].get<int>(), 0) << preview["dry_run"].dump();
  EXPECT_EQ(preview["dry_run"]["out_of_travel"].get<int>(), 0);
  EXPECT_EQ(preview["dry_run"]["misses"].get<int>(), 0) << preview["dry_run"].dump();
  EXPECT_GT(preview["estimate"]["time_s"].get<double>(), 0);
  EXPECT_NEAR(preview["dry_run"]["time_s"].get<double>() / preview["estimate"]["time_s"].get<double>(), 1.0, 0.1);
}

TEST(CmmdJob, ALinkDroppedMidJobPausesItWithCommLostAndResumeFinishesIt) {
  const auto dir = scratch("drop");
  const auto scan = testing::sample_scan(dir / "scan");
  json sim_config = testing::sample_sim_block();
  sim_config["faults"] = {{"drop_link_after_commands", 400}};
  {
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "sim_drop.json") << sim_config.dump();
  }
  SimulatorProcess sim(dir / "sim_drop.json", 200);
  CmmdInstance cmmd(dir / "cmmd", modbus_block(sim.port),
                    {{"machine_description", CMMD_SOURCE_DIR "/config/machine.json"}});
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  const int id = testing::submit_job(client, scan, {{"registration", testing::sample_measure_plate(dir / "scan")}});
  const json paused = testing::wait_for_job(client, id, {"paused"}, 600);
  ASSERT_FALSE(paused["fault"].is_null()) << paused.dump();
  EXPECT_EQ(paused["fault"]["kind"], "CommLost") << paused.dump();
  client.call("job.resume", {{"job", id}});
  testing::wait_for_job(client, id, {"done"}, 900);
}

// A stylus that triggers at the start of a touch's move and again as the resume takes it back along
// the search line: the ball must not be driven anywhere else from there. The job holds, saying so;
// the next resume leaves the line and finishes.
TEST(CmmdJob, AResumeThatCannotLeaveTheTouchInProgressHoldsTheJobInsteadOfMovingOn) {
  const auto dir = scratch("stuck");
  const auto scan = testing::sample_scan(dir / "scan");
  json machine = testing::sample_sim_block();
  machine["faults"] = {{"spurious_trigger_at_motion", 60}, {"spurious_trigger_count", 2}};
  CmmdInstance cmmd(dir / "cmmd", machine);
  cmmd.start();
  daemon::RpcClient client = cmmd.client();
  const int id = testing::submit_job(client, scan, {{"registration", testing::sample_measure_plate(dir / "scan")}});
  const json tripped = testing::wait_for_job(client, id, {"paused"}, 600);
  ASSERT_EQ(tripped["fault"]["kind"], "EarlyTrigger") << tripped.dump();
  const auto line_file = cmmd.folder() / "state" / "touch_in_progress.json";
  ASSERT_TRUE(std::filesystem::exists(line_file));

  // The next hold is awaited as it is announced: right after job.resume, job.get may still show
  // the old one (the worker has not taken the job up yet).
  daemon::RpcClient watch = cmmd.client();
  watch.call("server.subscribe", {{"topics", {"job"}}});
  client.call("job.resume", {{"job", id}});
  testing::await_job(watch, id, "the hold after the resume", testing::job_state_is(id, "paused"), 600,
                     testing::job_ended);
  const json stuck = client.call("job.get", {{"job", id}});
  ASSERT_FALSE(stuck["fault"].is_null()) << stuck.dump();
  EXPECT_EQ(stuck["fault"]["kind"], "Safety") << stuck.dump();
  EXPECT_NE(stuck["reason"].get<std::string>().find("could not leave the touch"), std::string::npos) << stuck.dump();
  EXPECT_TRUE(std::filesystem::exists(line_file)) << "the search line must stay recorded for the next mover";

  client.call("job.resume", {{"job", id}});
  testing::wait_for_job(client, id, {"done"}, 900);
  EXPECT_FALSE(std::filesystem::exists(line_file));
  EXPECT_EQ(cmmd.terminate(), 0);
}

}  // namespace
}  // namespace cmm
