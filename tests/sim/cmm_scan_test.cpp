// Runs the real cmm-scan binary: what it writes must be what the library makes for the same options,
// and bad flags must end in exit 2 with a message.
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
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

}  // namespace
}  // namespace cmm::sim
