// The merged PLY: read back by geometry's own reader (counts, exact coordinates), its attributes
// decoded by hand, the atomic write, and the refusal of points still in the machine frame.
#include <unistd.h>

#include "planner/measured_cloud.hpp"

#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <variant>

#include "geometry/file_error.hpp"
#include "geometry/mesh_io.hpp"

namespace {

namespace fs = std::filesystem;
using cmm::planner::MeasuredPoint;
using cmm::planner::PointFrame;
using cmm::planner::Vec3;

class MergedCloud : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("measured_cloud_test_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

MeasuredPoint measured(int id, const Vec3& position, double sigma) {
  MeasuredPoint p;
  p.id = id;
  p.frame = PointFrame::scan;
  p.position = position;
  p.sigma_mm = sigma;
  return p;
}

TEST_F(MergedCloud, ReadsBackWithGeometryReaderAndCarriesTheAttributes) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> box(-50, 50);
  cmm::geometry::Points scan(100, 3);
  for (Eigen::Index i = 0; i < scan.rows(); ++i) scan.row(i) << box(rng), box(rng), box(rng) / 3;
  const std::vector<MeasuredPoint> probe = {measured(3, Vec3(1.000001, 2, 3), 0.0021),
                                            measured(4, Vec3(-7.5, 0.125, 1e-3), 0.0009),
                                            measured(9, Vec3(40, 41, 42), 0.075)};
  const fs::path file = dir_ / "merged.ply";
  cmm::planner::write_merged_ply(file, scan, probe, 0.2);
  EXPECT_TRUE(fs::exists(file));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1) << "a temp file was left";

  const cmm::geometry::ReadResult read = cmm::geometry::read_model(file);
  ASSERT_TRUE(std::holds_alternative<cmm::geometry::PointCloud>(read.model));
  const auto& cloud = std::get<cmm::geometry::PointCloud>(read.model);
  ASSERT_EQ(cloud.points.rows(), 103);
  for (Eigen::Index i = 0; i < scan.rows(); ++i) EXPECT_EQ(cloud.points.row(i), scan.row(i)) << i;
  for (std::size_t k = 0; k < probe.size(); ++k) {
    EXPECT_EQ(Vec3(cloud.points.row(100 + k).transpose()), probe[k].position) << k;
  }

  // The attributes, from the bytes: header, then 29-byte records (3 doubles, uchar, float).
  std::ifstream in(file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string end = "end_header\n";
  const std::size_t body = bytes.find(end) + end.size();
  const std::string header = bytes.substr(0, body);
  EXPECT_NE(header.find("format binary_little_endian 1.0\n"), std::string::npos);
  EXPECT_NE(header.find("element vertex 103\n"), std::string::npos);
  EXPECT_NE(header.find("property uchar source\nproperty float uncertainty_mm\n"), std::string::npos);
  ASSERT_EQ(bytes.size(), body + 103 * 29);
  const auto source = [&](int i) { return static_cast<unsigned char>(bytes[body + i * 29 + 24]); };
  const auto uncertainty = [&](int i) {
    float value;
    std::memcpy(&value, bytes.data() + body + i * 29 + 25, sizeof value);  // the test host is little endian
    return value;
  };
  EXPECT_EQ(source(0), cmm::planner::merged_source_scan);
  EXPECT_EQ(source(99), cmm::planner::merged_source_scan);
  EXPECT_FLOAT_EQ(uncertainty(50), 0.2f);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(source(100 + k), cmm::planner::merged_source_measured);
    EXPECT_FLOAT_EQ(uncertainty(100 + k), static_cast<float>(probe[k].sigma_mm));
  }
}

TEST_F(MergedCloud, ReplacesAnOldFileWhole) {
  const fs::path file = dir_ / "merged.ply";
  { std::ofstream(file) << "old contents"; }
  cmm::planner::write_merged_ply(file, cmm::geometry::Points(0, 3), {measured(1, Vec3(1, 2, 3), 0.001)}, 0.2);
  const cmm::geometry::ReadResult read = cmm::geometry::read_model(file);
  const auto& cloud = std::get<cmm::geometry::PointCloud>(read.model);
  ASSERT_EQ(cloud.points.rows(), 1);
  EXPECT_EQ(Vec3(cloud.points.row(0).transpose()), Vec3(1, 2, 3));
}

TEST_F(MergedCloud, RefusesPointsStillInTheMachineFrame) {
  MeasuredPoint in_m = measured(17, Vec3::Zero(), 0.001);
  in_m.frame = PointFrame::machine;
  const fs::path file = dir_ / "merged.ply";
  try {
    cmm::planner::write_merged_ply(file, cmm::geometry::Points(0, 3), {in_m}, 0.2);
    FAIL();
  } catch (const cmm::planner::CompensationError& e) {
    EXPECT_EQ(e.id(), 17);
    EXPECT_NE(std::string(e.what()).find("to_scan_frame"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(file));
}

TEST_F(MergedCloud, ReportsAFolderThatDoesNotExist) {
  const fs::path file = dir_ / "missing" / "merged.ply";
  try {
    cmm::planner::write_merged_ply(file, cmm::geometry::Points(0, 3), {}, 0.2);
    FAIL();
  } catch (const cmm::geometry::FileError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(file.string() + ": ", 0), 0u) << e.what();
    EXPECT_EQ(e.error_number(), ENOENT);
  }
}

}  // namespace
