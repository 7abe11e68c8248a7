// Runs the real cmm-scan binary: what it writes must be what the library makes for the same options,
// and bad flags must end in exit 2 with a message.
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "geometry/analytic_parts.hpp"
#include "geometry/mesh_io.hpp"
#include "sim/raw_scan.hpp"
#include "sim/scanned_mesh.hpp"
#include "tests/tools/run_command.hpp"

namespace cmm::sim {
namespace {

test::CommandResult run_scan(const std::string& flags) {
  return test::run_command(std::string(CMMD_BINARY_DIR) + "/sim/cmm-scan " + flags);
}

// PLY keeps doubles exactly, so the files must equal the library's output to the bit.
TEST(CmmScan, WritesMeshCloudAndTruthAndRefusesBadFlags) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("cmm_scan_test_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string mesh = (dir / "mesh.ply").string(), cloud = (dir / "cloud.ply").string(),
                    truth = (dir / "truth.json").string();
  const test::CommandResult ok = run_scan("--part cube --edge-length 2 --spacing 2 --seed 4 --mesh " + mesh + " --cloud " +
                                    cloud + " --truth " + truth);
  ASSERT_EQ(ok.exit_code, 0) << ok.output;

  const geometry::AnalyticPart cube = geometry::make_cube(40, 2.0);
  const std::vector<ScanView> views = default_views({.seed = 4});
  const ScannedMesh expected = synthesize_scanned_mesh(cube.mesh, {.views = views, .seed = 4});
  const geometry::TriangleMesh written = geometry::read_mesh(mesh);
  EXPECT_EQ(written.faces, expected.mesh.faces);
  EXPECT_EQ(written.vertices, expected.mesh.vertices);
  const RawScan raw = synthesize_raw_scan(cube.mesh, {.spacing_mm = 2.0, .views = views, .seed = 4});
  const auto cloud_model = geometry::read_model(cloud).model;
  ASSERT_TRUE(std::holds_alternative<geometry::PointCloud>(cloud_model));
  EXPECT_EQ(std::get<geometry::PointCloud>(cloud_model).points, raw.cloud.points);

  std::ifstream in(truth);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("\"removed_faces\": " + std::to_string(expected.removed_faces.size())), std::string::npos)
      << text.str();
  EXPECT_NE(text.str().find("\"seed\": 4"), std::string::npos);

  for (const std::string& bad : {std::string("--part teapot --mesh ") + mesh, "--part cube --noise -1 --mesh " + mesh,
                                 "--part cube --edge-length 0 --mesh " + mesh, std::string("--part cube"),
                                 "--part cube --mesh " + mesh + " --bogus 1"}) {
    const test::CommandResult refused = run_scan(bad);
    EXPECT_EQ(refused.exit_code, 2) << bad << "\n" << refused.output;
    EXPECT_FALSE(refused.output.empty()) << bad;
  }
  fs::remove_all(dir);
}

// The sampling flags (issue 36) reach the library as given, the truth records them and the bands'
// borders, and every bad value is refused naming its flag.
TEST(CmmScan, SamplingFlagsGiveTheLibrarysScanAndBadOnesAreRefused) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("cmm_scan_sampling_test_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string cloud = (dir / "cloud.ply").string(), truth = (dir / "truth.json").string();
  const std::string flags = "--part plate_small_openings --edge-length 2 --spacing 2 --seed 3 --noise 0.05 --sampling grid "
                            "--noise-model isotropic --views 4 --view-offset 0.015 --view-coverage 0.7 --view-density 1,2,1,0.5";
  const test::CommandResult ok = run_scan(flags + " --cloud " + cloud + " --truth " + truth);
  ASSERT_EQ(ok.exit_code, 0) << ok.output;

  const geometry::AnalyticPart plate = geometry::make_analytic_part("plate_small_openings", 2.0);
  const RawScan raw = synthesize_raw_scan(plate.mesh, {.spacing_mm = 2.0,
                                                       .noise_sigma_mm = 0.05,
                                                       .views = views_with_offset(4, 0.015, 3),
                                                       .seed = 3,
                                                       .sampling = ScanSampling::grid,
                                                       .noise_model = ScanNoise::isotropic,
                                                       .view_coverage = 0.7,
                                                       .view_density = {1, 2, 1, 0.5}});
  const auto cloud_model = geometry::read_model(cloud).model;
  ASSERT_TRUE(std::holds_alternative<geometry::PointCloud>(cloud_model));
  EXPECT_EQ(std::get<geometry::PointCloud>(cloud_model).points, raw.cloud.points);

  std::ifstream in(truth);
  std::stringstream text;
  text << in.rdbuf();
  for (const std::string& expected : {std::string("\"sampling\": \"grid\""), std::string("\"noise_model\": \"isotropic\""),
                                      std::string("\"view_offset_mm\": 0.015"), std::string("\"coverage\": ["),
                                      std::string("\"borders\": ["), "\"points\": " + std::to_string(raw.cloud.points.rows())})
    EXPECT_NE(text.str().find(expected), std::string::npos) << expected << "\n" << text.str();

  const std::string part = "--part cube --cloud " + cloud + " ";
  for (const auto& [bad, names] : std::vector<std::pair<std::string, std::string>>{
           {"--sampling hexagonal", "--sampling"},
           {"--noise-model pink", "--noise-model"},
           {"--views 0", "--views"},
           {"--view-offset -0.1", "--view-offset"},
           {"--view-coverage 0", "--view-coverage"},
           {"--view-coverage 1.5", "--view-coverage"},
           {"--view-coverage lots", "--view-coverage"},
           {"--view-density 1,0,1,1,1,1,1", "--view-density"},
           {"--view-density 1,2", "--view-density"},
           {"--views 3 --view-density 1,2,1,1", "--view-density"}}) {
    const test::CommandResult refused = run_scan(part + bad);
    EXPECT_EQ(refused.exit_code, 2) << bad << "\n" << refused.output;
    EXPECT_NE(refused.output.find(names), std::string::npos) << bad << "\n" << refused.output;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cmm::sim
