// XYZ specifics: separators, comments and blank lines, optional normals.
#include "geometry/xyz_io.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "geometry/file_error.hpp"

namespace cmm::geometry {
namespace {

TEST(Xyz, ReadsBlankOrCommaSeparatedLinesWithComments) {
  const ReadResult result = read_xyz("scan.xyz", "# scan 1\n\n1 2 3\n4,5,6  # a comment\r\n\t+7e-3 ,8, 9\n");
  const auto& cloud = std::get<PointCloud>(result.model);
  Points points(3, 3);
  points << 1, 2, 3, 4, 5, 6, 7e-3, 8, 9;
  EXPECT_EQ(cloud.points, points);
  EXPECT_EQ(cloud.normals.rows(), 0);
  EXPECT_EQ(result.report.vertices_read, 3U);
}

TEST(Xyz, SixColumnsCarryNormals) {
  const ReadResult result = read_xyz("scan.xyz", "1 2 3 0 0 1\n4 5 6 0 1 0\n");
  EXPECT_EQ(std::get<PointCloud>(result.model).normals.row(1), Eigen::RowVector3d(0, 1, 0));
}

TEST(Xyz, EveryLineNeedsTheFirstLinesColumns) {
  try {
    read_xyz("mixed.xyz", "1 2 3 0 0 1\n4 5 6\n");
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("mixed.xyz: line 2: 3 values, but the first point (line 1) has 6"));
  }
}

TEST(Xyz, WritesOnePointPerLine) {
  PointCloud cloud;
  cloud.points.resize(2, 3);
  cloud.points << 0.1, 2, -3, 4, 5, 6;
  std::ostringstream out;
  write_xyz(out, cloud);
  EXPECT_EQ(out.str(), "0.1 2 -3\n4 5 6\n");
}

}  // namespace
}  // namespace cmm::geometry
