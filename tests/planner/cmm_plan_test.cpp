// Runs the real cmm-plan binary on files and checks its exit codes, messages and plan JSON, every
// plan validated against docs/plan.schema.json with Debian's python3-jsonschema.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace {

namespace fs = std::filesystem;

struct CommandResult {
  int exit_code;
  std::string output;  // stdout and stderr
};

CommandResult run(const std::string& command) {
  CommandResult result{-1, {}};
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe)) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

class CmmPlan : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("cmm_plan_test_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  CommandResult plan(const std::string& model, const std::string& output, const std::string& flags = "") const {
    return run(std::string(CMMD_BINARY_DIR) + "/planner/cmm-plan " + model + " -o " + output + " " + flags);
  }

  void make_part(const std::string& part, const std::string& file, const std::string& flags = "") const {
    const CommandResult r = run(std::string(CMMD_BINARY_DIR) + "/tests/make-analytic-part " + part + " -o " + file + " " + flags);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }

  static nlohmann::json load(const std::string& file) {
    std::ifstream in(file);
    return nlohmann::json::parse(in);
  }

  static void expect_valid(const std::string& plan_file) {
    const CommandResult r = run(std::string(CMMD_SYSTEM_PYTHON) + " " CMMD_SOURCE_DIR "/tests/planner/validate_plan.py " +
                      CMMD_SOURCE_DIR "/docs/plan.schema.json " + plan_file);
    EXPECT_EQ(r.exit_code, 0) << r.output;
  }

  fs::path dir_;
};

TEST_F(CmmPlan, SamplePartPlansWithHolesAndValidates) {
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("5 hole"), std::string::npos) << r.output;  // summary line counts holes
  expect_valid(path("plan.json"));
  const auto plan = load(path("plan.json"));
  EXPECT_EQ(plan["schema"], "cmmd.plan/1");
  EXPECT_EQ(plan["holes"].size(), 5u);
  EXPECT_TRUE(plan["registration"].is_null());
  for (const auto& p : plan["edge_points"]) EXPECT_NE(p["kind"], "boundary");
}

TEST_F(CmmPlan, NoisyScanMeshPlansAndValidates) {
  make_part("plate_with_holes", path("plate.stl"), "--edge-length 1 --noise 0.1 --seed 7");
  const CommandResult r = plan(path("plate.stl"), path("plan.json"), "--spacing 3");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("noisy"), std::string::npos) << r.output;
  expect_valid(path("plan.json"));
  EXPECT_EQ(load(path("plan.json"))["holes"].size(), 5u);
}

TEST_F(CmmPlan, LostBoreWallsGiveOpenBoundaryHolesWithInferredNormals) {
  make_part("case3_block", path("scan.ply"), "--edge-length 2 --open-bores");
  const CommandResult r = plan(path("scan.ply"), path("plan.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_valid(path("plan.json"));
  const auto plan = load(path("plan.json"));
  // Each through hole leaves two open rims (top and bottom), each found as a hole.
  ASSERT_EQ(plan["holes"].size(), 10u);
  for (const auto& hole : plan["holes"]) {
    EXPECT_EQ(hole["source"], "open_boundary");
    EXPECT_TRUE(hole["depth"].is_null());
    const double radius = hole["radius"];
    EXPECT_TRUE(std::abs(radius - 21) < 0.21 || std::abs(radius - 5) < 0.05) << radius;
    for (int id : hole["rim_point_ids"]) {
      const auto& point = plan["edge_points"][id];
      EXPECT_EQ(point["kind"], "hole_rim");
      EXPECT_TRUE(point["normals_inferred"]);
      EXPECT_TRUE(point["convex"]);
      EXPECT_NEAR(point["interior_angle_deg"].get<double>(), 90.0, 1.0);
    }
  }
}

TEST_F(CmmPlan, UnitlessMeshIsScaled) {
  const CommandResult r = plan(CMMD_TEST_DATA_DIR "/fandisk.ply", path("plan.json"), "--scale 100 --spacing 2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_valid(path("plan.json"));
  const auto plan = load(path("plan.json"));
  EXPECT_GT(plan["edge_points"].size(), 100u);
  EXPECT_EQ(plan["model"]["topology"]["components"], 1);
}

TEST_F(CmmPlan, OpenMeshReportsUnprobeableBoundaries) {
  const CommandResult r = plan(CMMD_TEST_DATA_DIR "/blade.ply", path("plan.json"), "--scale 1 --spacing 1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_valid(path("plan.json"));
  int boundary = 0;
  const auto plan = load(path("plan.json"));
  for (const auto& p : plan["edge_points"]) {
    if (p["kind"] != "boundary") continue;
    ++boundary;
    EXPECT_FALSE(p["probeable"]);
    EXPECT_TRUE(p["n_down"].is_null());
    EXPECT_NE(p["reason"].get<std::string>().find("open boundary"), std::string::npos);
  }
  EXPECT_GT(boundary, 0);
}

TEST_F(CmmPlan, PointCloudIsRefusedClearly) {
  std::ofstream(path("scan.xyz")) << "0 0 0\n1 0 0\n0 1 0\n";
  const CommandResult r = plan(path("scan.xyz"), path("plan.json"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("point cloud (3 points"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("triangle mesh"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

TEST_F(CmmPlan, ScaleBeyondDoubleRangeIsRefused) {
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"), "--scale 1e308");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("beyond the range"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

TEST_F(CmmPlan, UnwritableOutputFailsAndLeavesNothing) {
  const std::string output = path("missing-folder/plan.json");
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", output);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("cannot write " + output), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(output));
  EXPECT_FALSE(fs::exists(output + ".partial"));
}

TEST_F(CmmPlan, BrokenFileNamesFileAndLine) {
  std::ofstream(path("broken.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n";
  const CommandResult r = plan(path("broken.obj"), path("plan.json"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("broken.obj: line 4"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

}  // namespace
