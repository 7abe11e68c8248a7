// Real files nobody on the project wrote: two CC0 meshes kept in tests/data, and a raw range scan
// read from ../shared/data, which is not free for commercial use and so is never copied here.
#include <gtest/gtest.h>

#include <filesystem>

#include "geometry/mesh_io.hpp"

namespace cmm::geometry {
namespace {

namespace fs = std::filesystem;

TEST(SharedData, FandiskIsAClosedCadMesh) {
  ReadReport report;
  const TriangleMesh mesh = read_mesh(fs::path(CMMD_TEST_DATA_DIR) / "fandisk.ply", &report);
  EXPECT_EQ(mesh.vertices.rows(), 6475);
  EXPECT_EQ(mesh.faces.rows(), 12946);
  EXPECT_EQ(report.degenerate_faces_dropped + report.duplicate_faces_dropped, 0U);
}

TEST(SharedData, BladeIsAMeshWithOpenEnds) {
  const TriangleMesh mesh = read_mesh(fs::path(CMMD_TEST_DATA_DIR) / "blade.ply");
  EXPECT_EQ(mesh.vertices.rows(), 8231);
  EXPECT_EQ(mesh.faces.rows(), 16222);
}

TEST(SharedData, BunnyRangeScanIsACloud) {
  const fs::path file = fs::path(CMMD_SHARED_DATA_DIR) / "bun000.ply";
  if (!fs::exists(file)) {
    GTEST_SKIP() << file << " is absent: the ../shared/data folder (developer machines and CI only) "
                 << "is not next to this checkout, so the Stanford bunny scan cannot be read";
  }
  const ReadResult result = read_model(file);
  ASSERT_TRUE(std::holds_alternative<PointCloud>(result.model));
  const Points& points = std::get<PointCloud>(result.model).points;
  EXPECT_EQ(points.rows(), 40256);
  const Vec3 low = points.colwise().minCoeff(), high = points.colwise().maxCoeff();
  EXPECT_NEAR(low.x(), -0.095, 1e-3);
  EXPECT_NEAR(high.x(), 0.061, 1e-3);
  EXPECT_NEAR(low.y(), 0.036, 1e-3);
  EXPECT_NEAR(high.y(), 0.188, 1e-3);
  EXPECT_NEAR(low.z(), -0.059, 1e-3);
  EXPECT_NEAR(high.z(), 0.059, 1e-3);
}

}  // namespace
}  // namespace cmm::geometry
