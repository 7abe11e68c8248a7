// cmmctl, the real binary, against a real cmmd: status, jobs, submit --corners --watch with its result
// summary, ports, and what an operator sees when cmmd is not there.
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "cmmd_instance.hpp"
#include "sim/sim_config.hpp"
#include "tests/daemon/fresh_folder.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm {
namespace {

using nlohmann::json;

const std::string kCmmctl = CMMD_BINARY_DIR "/daemon/cmmctl";

// corners.json for --corners: the scanned plate corners (cmm-scan) paired with where the simulator
// really put them in M, as a careful operator would have measured them.
std::filesystem::path given_corners(const std::filesystem::path& scan_folder) {
  const json measure = testing::sample_measure_plate(scan_folder).at("measure_plate");
  const sim::SimConfig truth = sim::sim_config_from_json(testing::sample_sim_block());
  const description::Plate plate = description::default_plate();
  json corners = json::array();
  for (const json& c : measure.at("scan_corners")) {
    const Eigen::Vector3d m = truth.T_M_P * plate.corner(c.at("id").get<int>());
    corners.push_back({{"id", c["id"]}, {"scan", c["scan"]}, {"machine", {m.x(), m.y(), m.z()}}});
  }
  const std::filesystem::path file = scan_folder / "given_corners.json";
  std::ofstream(file) << json{{"corners", corners}}.dump(1) << "\n";
  return file;
}

TEST(Cmmctl, StatusSubmitWatchJobsAndResultAgainstARunningCmmd) {
  const auto dir = daemon::fresh_folder("cmmctl");
  json sim_block = testing::sample_sim_block();
  sim_block["time_scale"] = 50;
  testing::CmmdInstance cmmd(dir / "cmmd", sim_block);
  cmmd.start();
  const std::string ctl = kCmmctl + " --endpoint unix:" + (dir / "cmmd" / "run" / "cmmd.sock").string();

  auto r = cmm::test::run_command(ctl + " status");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("machine  sim, link"), std::string::npos) << r.output;
  r = cmm::test::run_command(ctl + " jobs");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("no jobs"), std::string::npos) << r.output;

  const auto scan = testing::sample_scan(dir / "scan");
  const auto corners = given_corners(dir / "scan");
  r = cmm::test::run_command(ctl + " qualify");  // no touch on an unqualified tip
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = cmm::test::run_command(ctl + " status");
  EXPECT_NE(r.output.find("tip      T1 (active) r "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("tip      T2 r 2.5000 mm, NOT QUALIFIED"), std::string::npos) << r.output;
  r = cmm::test::run_command(ctl + " submit " + scan.string() + " --corners " + corners.string() +
                             " --spacing 8 --name plate-check --watch");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* line : {"job 1 queued (sha256:", "job 1: probing", "job 1: done", "features    ", "measured    ",
                           "register    given, RMS residual", "deviation   edges vs reference", "machine     "})
    EXPECT_NE(r.output.find(line), std::string::npos) << line << " missing in:\n" << r.output;

  r = cmm::test::run_command(ctl + " jobs");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("job 1  done"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("plate-check"), std::string::npos) << r.output;
  r = cmm::test::run_command(ctl + " --json jobs");
  EXPECT_EQ(json::parse(r.output).at(0).at("state"), "done") << r.output;
  r = cmm::test::run_command(ctl + " result 1 --format csv -o " + (dir / "result.csv").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_GT(std::filesystem::file_size(dir / "result.csv"), 100u);

  // cmmd's refusals come back as a message with the code, and exit 1.
  r = cmm::test::run_command(ctl + " result 99");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("-32010"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no job 99"), std::string::npos) << r.output;
  EXPECT_EQ(cmmd.terminate(), 0);
}

// The README's sample corners name their plate by a path relative to the corners file; cmmd
// cannot read the client's files, so cmmctl sends the plate inline (issue 13: it sent the path).
// The shop's path: a raw multi-view scan (points, strays, noise) goes to cmmd as it is; cmmd thins and
// meshes it, stores the mesh it planned on in the job's folder, and measures the part on it.
TEST(Cmmctl, ARawScanIsMeshedByCmmdAndMeasured) {
  const auto dir = daemon::fresh_folder("cmmctl-raw-scan");
  testing::CmmdInstance cmmd(dir / "cmmd", testing::timed_sim_block(50));
  cmmd.start();
  const std::string ctl = kCmmctl + " --endpoint unix:" + (dir / "cmmd" / "run" / "cmmd.sock").string();
  std::filesystem::create_directories(dir / "scan");
  std::ofstream(dir / "scan" / "sim.json") << testing::sample_sim_block().dump() << "\n";
  auto r = cmm::test::run_command(std::string(CMMD_BINARY_DIR "/sim/cmm-scan --sim-config ") + (dir / "scan" / "sim.json").string() +
                                  " --spacing 0.8 --noise 0.05 --cloud " + (dir / "scan" / "raw.pcd").string() +
                                  " --plate-corners " + (dir / "scan" / "plate_corners.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(cmm::test::run_command(ctl + " qualify").exit_code, 0);
  r = cmm::test::run_command(ctl + " submit " + (dir / "scan" / "raw.pcd").string() + " --tolerance 0.1 --spacing 8 --measure-plate " +
                             (dir / "scan" / "plate_corners.json").string() + " --watch");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("job 1: done"), std::string::npos) << r.output;
  EXPECT_TRUE(std::filesystem::exists(cmmd.job_folder(1) / "reference.ply"));
  const json plan = testing::read_json_file(cmmd.job_folder(1) / "plan.json");
  ASSERT_TRUE(plan["model"]["scan"].is_object()) << plan["model"].dump();
  EXPECT_EQ(plan["model"]["scan"]["tolerance_mm"], 0.1);
  EXPECT_GT(plan["model"]["scan"]["outliers_removed"].get<int>(), 0);
  const json result = testing::read_json_file(cmmd.job_folder(1) / "result.json");
  EXPECT_GT(result["summary"]["edge_points"]["measured"].get<int>(), 20) << result["summary"].dump();
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(Cmmctl, SubmitSendsAPlateTheCornersFileNamesInline) {
  const auto dir = daemon::fresh_folder("cmmctl-sample-corners");
  testing::CmmdInstance cmmd(dir / "cmmd", testing::sample_sim_block());
  cmmd.start();
  const std::string ctl = kCmmctl + " --endpoint unix:" + (dir / "cmmd" / "run" / "cmmd.sock").string();
  auto r = cmm::test::run_command(ctl + " submit " CMMD_SOURCE_DIR "/config/samples/case3_block.ply --corners " CMMD_SOURCE_DIR
                                  "/config/samples/case3_block.corners.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("job 1 queued"), std::string::npos) << r.output;
  const json request = testing::read_json_file(cmmd.job_folder(1) / "request.json");
  EXPECT_EQ(request["registration"]["plate"]["corners"],
            testing::read_json_file(CMMD_SOURCE_DIR "/config/plate.json")["corners"]) << request;
  r = cmm::test::run_command(ctl + " cancel 1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(cmmd.terminate(), 0);
}

TEST(Cmmctl, SaysSoAndExitsNonZeroWhenCmmdIsNotThere) {
  const auto dir = daemon::fresh_folder("cmmctl-none");
  const std::string socket = (dir / "no" / "cmmd.sock").string();
  for (const char* command : {"status", "jobs", "home"}) {
    const auto r = cmm::test::run_command(kCmmctl + " --endpoint unix:" + socket + " " + command);
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.output;
    EXPECT_NE(r.output.find(socket), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("is cmmd running?"), std::string::npos) << r.output;
  }
  const auto bad = cmm::test::run_command(kCmmctl + " --endpoint http://localhost status");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("neither tcp://HOST:PORT nor unix:/PATH"), std::string::npos) << bad.output;
}

TEST(Cmmctl, PortsListsSerialPortsWithoutCmmd) {
  const auto r = cmm::test::run_command(kCmmctl + " --endpoint unix:/nonexistent/cmmd.sock ports");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_FALSE(r.output.empty());
}

}  // namespace
}  // namespace cmm
