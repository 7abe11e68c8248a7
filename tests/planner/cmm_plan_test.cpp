// Runs the real cmm-plan binary on files and checks its exit codes, messages and plan JSON, every
// plan validated against docs/plan.schema.json with Debian's python3-jsonschema.
#include <unistd.h>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "dmis_checker.hpp"
#include "hal/description/machine_description.hpp"
#include "tests/tools/run_command.hpp"

namespace {

namespace fs = std::filesystem;

using cmm::test::CommandResult;
using cmm::test::run_command;

// A registration scene with a known truth: the 200 × 150 mm plate of config/plate.json under the
// case-3 block, its frame P at (−50, −30, 0) in S, and S turned 30° about z and moved by
// (250, 300, 10) into M. Corners and the chamfer's mid-face point are given exactly in both frames.
struct RegistrationScene {
  Eigen::Isometry3d T_M_S = Eigen::Translation3d(250, 300, 10) * Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ());
  Eigen::Isometry3d T_S_P = Eigen::Isometry3d(Eigen::Translation3d(-50, -30, 0));
  std::array<Eigen::Vector3d, 4> corners_P = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(200, 0, 0),
                                              Eigen::Vector3d(200, 150, 0), Eigen::Vector3d(0, 150, 0)};
  static nlohmann::json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
  // `label_shift` labels the machine corners from another corner: 2 is the rectangle's blind spot.
  nlohmann::json corners_json(int label_shift = 0) const {
    nlohmann::json j = {{"noise_mm", 0.01}, {"corners", nlohmann::json::array()}};
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d scan = T_S_P * corners_P[k];
      const Eigen::Vector3d machine = T_M_S * T_S_P * corners_P[(k + label_shift) % 4];
      j["corners"].push_back({{"id", k + 1}, {"scan", vec(scan)}, {"machine", vec(machine)}});
    }
    j["fiducial"] = {{"machine", vec(T_M_S * T_S_P * Eigen::Vector3d(2.5, 2.5, -5))}};
    return j;
  }
};

class CmmPlan : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("cmm_plan_test_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  CommandResult plan(const std::string& model, const std::string& output, const std::string& flags = "") const {
    return run_command(std::string(CMMD_BINARY_DIR) + "/planner/cmm-plan " + model + " -o " + output + " " + flags);
  }

  void make_part(const std::string& part, const std::string& file, const std::string& flags = "") const {
    const CommandResult r = run_command(std::string(CMMD_BINARY_DIR) + "/tests/make-analytic-part " + part + " -o " + file + " " + flags);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }

  static nlohmann::json load(const std::string& file) {
    std::ifstream in(file);
    return nlohmann::json::parse(in);
  }

  static void expect_valid(const std::string& plan_file) {
    const CommandResult r = run_command(std::string(CMMD_SYSTEM_PYTHON) + " " CMMD_SOURCE_DIR "/tests/planner/validate_plan.py " +
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
  EXPECT_EQ(plan["schema"], "cmmd.plan/2");
  EXPECT_EQ(plan["holes"].size(), 5u);
  EXPECT_TRUE(plan["registration"].is_null());
  for (const auto& p : plan["edge_points"]) EXPECT_NE(p["kind"], "boundary");
  // Without --probe-radius the active tip's qualified radius is the plan's.
  EXPECT_EQ(plan["machine"]["active_tip"], "T1");
  EXPECT_EQ(plan["probe_radius"], 1.0);
  EXPECT_NE(r.output.find("T_M_S = identity"), std::string::npos) << r.output;
  // Every point is either planned with its touches in the program or says why not; the estimate
  // is at or above its lower bound.
  std::size_t touches = 0, two_touch = 0;
  for (const auto& p : plan["edge_points"]) {
    if (p["probeable"]) {
      EXPECT_GE(p["touches"].size(), 2u);
      touches += p["touches"].size();
      two_touch += p["method"] == "two_touch";
    } else {
      EXPECT_TRUE(p["reason"].is_string()) << p.dump();
      EXPECT_TRUE(p["touches"].empty());
    }
  }
  EXPECT_GT(two_touch, 300u);
  for (const auto& h : plan["holes"]) touches += h["bore"].is_null() ? 0 : h["bore"]["touches"].size();
  EXPECT_EQ(plan["program"].size(), touches);
  EXPECT_GE(plan["estimate"]["time_s"].get<double>(), plan["estimate"]["lower_bound_s"].get<double>());
  // T1's 20 mm shaft cannot reach mid-depth of the 41 mm bores: each says so.
  for (const auto& h : plan["holes"]) EXPECT_NE(h["bore_reason"].get<std::string>().find("probe head"), std::string::npos);
}

TEST_F(CmmPlan, TwoThousandPointProgramIsWithinFifteenPercentOfItsBound) {
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"),
                               "--spacing 0.7 --probe-radius 2.5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto plan = load(path("plan.json"));
  EXPECT_GE(plan["edge_points"].size(), 2000u);
  const double time = plan["estimate"]["time_s"], bound = plan["estimate"]["lower_bound_s"];
  EXPECT_GT(plan["estimate"]["touches"].get<int>(), 2000);
  EXPECT_GE(time, bound);
  EXPECT_LE(time, 1.15 * bound);
}

TEST_F(CmmPlan, ProbeRadiusSelectsTheTipOfThatRadius) {
  const CommandResult r =
      plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"), "--probe-radius 2.5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_valid(path("plan.json"));
  const auto plan = load(path("plan.json"));
  EXPECT_EQ(plan["machine"]["active_tip"], "T2");
  // T2's 40 mm shaft reaches the bores' mid-depth: six touches each.
  for (const auto& h : plan["holes"]) {
    ASSERT_TRUE(h["bore"].is_object()) << h.dump();
    EXPECT_EQ(h["bore"]["touches"].size(), 6u);
  }
}

TEST_F(CmmPlan, RadiusNoTipHasIsPlannedForACopyAndSaysSo) {
  const CommandResult r =
      plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"), "--probe-radius 1.5");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto plan = load(path("plan.json"));
  EXPECT_EQ(plan["machine"]["active_tip"], "T1_r1.5");
  EXPECT_NE(plan["notes"].dump().find("no tip of the machine has radius 1.5 mm"), std::string::npos);
}

TEST_F(CmmPlan, RegistrationTakesTheProgramIntoTheMachineFrame) {
  const RegistrationScene scene;
  std::ofstream(path("corners.json")) << scene.corners_json().dump();
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"),
                               "--registration " + path("corners.json") + " --plate " CMMD_SOURCE_DIR "/config/plate.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("corner order confirmed by the fiducial"), std::string::npos) << r.output;
  expect_valid(path("plan.json"));
  const auto plan = load(path("plan.json"));
  const auto& T = plan["registration"]["T_M_S"];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(T[i][j].get<double>(), scene.T_M_S.matrix()(i, j), 1e-9) << i << "," << j;
  EXPECT_LT(plan["registration"]["rms_mm"].get<double>(), 1e-9);
  EXPECT_NEAR(plan["floor_z"].get<double>(), 10, 1e-9);  // the block's foot, on the plate, in M
  // Each planned touch aims at its edge point taken into M.
  int checked = 0;
  for (const auto& touch : plan["program"]) {
    if (touch["target"] != "edge") continue;
    const auto& position = plan["edge_points"][touch["edge_point"].get<int>()]["position"];
    const Eigen::Vector3d in_m = scene.T_M_S * Eigen::Vector3d(position[0], position[1], position[2]);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(touch["surface_point"][k].get<double>(), in_m[k], 1e-9);
    ++checked;
  }
  EXPECT_GT(checked, 600);
}

TEST_F(CmmPlan, RadiusTooSmallForTheActiveTipsShaftIsRefused) {
  const CommandResult r =
      plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"), "--probe-radius 0.3");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--probe-radius 0.3: no tip has that radius"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("wider than the ball"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

TEST_F(CmmPlan, ReadmeWorkflowRegistersTheSamplePart) {
  // The command of README.md and scripts/demo, with the sample corners and their plate reference.
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"),
                               "--probe-radius 2.5 --registration " CMMD_SOURCE_DIR
                               "/config/samples/case3_block.corners.json --dmis " + path("plan.dmi"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("corner order confirmed by the fiducial"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("5 of 5 bores"), std::string::npos) << r.output;
  expect_valid(path("plan.json"));
  const auto plan = load(path("plan.json"));
  EXPECT_LT(plan["registration"]["rms_mm"].get<double>(), 1e-3);  // the file's micrometre rounding
  EXPECT_TRUE(fs::exists(path("plan.dmi")));
}

TEST_F(CmmPlan, CornersShiftedByTwoAreRefused) {
  std::ofstream(path("corners.json")) << RegistrationScene().corners_json(2).dump();
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"),
                               "--registration " + path("corners.json") + " --plate " CMMD_SOURCE_DIR "/config/plate.json");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("registration refused"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("shifted by 2"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

TEST_F(CmmPlan, PlateWithoutRegistrationIsRefused) {
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"),
                               "--plate " CMMD_SOURCE_DIR "/config/plate.json");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("needs --registration"), std::string::npos) << r.output;
}

TEST_F(CmmPlan, BadMachineDescriptionNamesTheField) {
  nlohmann::json machine = cmm::description::to_json(cmm::description::default_machine());
  machine["max_speed_mm_s"] = -5;
  std::ofstream(path("machine.json")) << machine.dump();
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"),
                               "--machine " + path("machine.json"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("machine.json"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("max_speed_mm_s"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

TEST_F(CmmPlan, DmisOfTheProgramPassesTheStrictChecker) {
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"),
                               "--probe-radius 2.5 --dmis " + path("plan.dmi"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(path("plan.dmi"));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  cmm::planner::testing::DmisCheckOptions options;
  options.travel_box = cmm::description::machine_from_json(load(path("plan.json"))["machine"]).travel_box;
  const auto result = cmm::planner::testing::check_dmis(text, options);
  EXPECT_TRUE(result.ok()) << result;
  EXPECT_NE(text.find("SNSDEF"), std::string::npos);
  EXPECT_NE(text.find("PTMEAS/CART"), std::string::npos);
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

TEST_F(CmmPlan, ACloudTooSmallToFitIsRefusedClearly) {
  std::ofstream(path("scan.xyz")) << "0 0 0\n1 0 0\n0 1 0\n";
  const CommandResult r = plan(path("scan.xyz"), path("plan.json"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("scan.xyz: 3 points, fewer than the 26 one local surface fit needs"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

// A raw scan (points with the scanner's normals, strays, several views) is thinned, meshed and planned
// on like a mesh; the summary and the plan say how, and --emit-mesh writes the mesh planned on.
TEST_F(CmmPlan, ARawScanIsMeshedAndPlanned) {
  const CommandResult scan = run_command(std::string(CMMD_BINARY_DIR) + "/sim/cmm-scan --part cube --spacing 0.7 --noise 0.02 --cloud " +
                                         path("cube_scan.ply"));
  ASSERT_EQ(scan.exit_code, 0) << scan.output;
  const CommandResult r =
      plan(path("cube_scan.ply"), path("plan.json"), "--tolerance 0.05 --spacing 4 --emit-mesh " + path("mesh.ply"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* line : {"scan       ", "thin       bin ", "mesh       ", "scan time  outliers"})
    EXPECT_NE(r.output.find(line), std::string::npos) << line << " missing from\n" << r.output;
  EXPECT_TRUE(fs::exists(path("mesh.ply")));
  expect_valid(path("plan.json"));
  const nlohmann::json p = load(path("plan.json"));
  const nlohmann::json& s = p["model"]["scan"];
  ASSERT_TRUE(s.is_object()) << p["model"].dump();
  EXPECT_EQ(s["tolerance_mm"], 0.05);
  EXPECT_GT(s["points_in"].get<int>(), s["points_kept"].get<int>());
  EXPECT_GT(s["triangles"].get<int>(), 1000);
  EXPECT_GE(s["creases"].get<int>(), 8);  // the cube's edges between seen faces
  EXPECT_NE(p["delta_source"].get<std::string>().find("raw scan's own noise sigma"), std::string::npos);
  EXPECT_GT(p["edge_points"].size(), 20u);
}

TEST_F(CmmPlan, ScaleBeyondDoubleRangeIsRefused) {
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"), "--scale 1e308");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("beyond the range"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

// Models no machine could hold are refused before any feature is looked for, naming the vertex
// that is off; they once made cmm-plan allocate 12 GB in a minute (issue 13, D2).
TEST_F(CmmPlan, AModelBeyondTheTravelBoxIsRefusedBeforePlanning) {
  CommandResult r = plan(CMMD_TEST_DATA_DIR "/hostile/stray_vertex_cube.stl", path("plan.json"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("the farthest vertex is"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("(2600000.000, 40.000, 40.000)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("travel box"), std::string::npos) << r.output;
  r = plan(CMMD_TEST_DATA_DIR "/hostile/huge_tetrahedron.ply", path("plan.json"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("1000000000.0 × 1000000000.0 × 1000000000.0 mm"), std::string::npos) << r.output;
  // The sample part is fine at scale 1 and refused at 100 (88 m long).
  r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"), "--scale 100");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("(scale 100)"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(path("plan.json")));
}

TEST_F(CmmPlan, ASpacingThatWouldGiveTooManyPointsIsRefused) {
  const CommandResult r = plan(CMMD_SOURCE_DIR "/config/samples/case3_block.ply", path("plan.json"), "--spacing 0.01");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("more than the limit of 20000"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("coarser spacing"), std::string::npos) << r.output;
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
