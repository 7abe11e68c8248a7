// OFF specifics: comments, counts beside the header word, polygons, the NOFF and COFF variants.
#include "geometry/off_io.hpp"

#include <gtest/gtest.h>

#include <sstream>
#include <string>

namespace cmm::geometry {
namespace {

TEST(Off, ReadsCommentsCountsOnTheHeaderLineAndPolygons) {
  const std::string text =
      "OFF 5 2 0 # counts beside the header word\n"
      "# vertices\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\n0.5 0.5 1\n"
      "4 0 1 2 3\n3 0 1 4 255 0 0\n";  // the second face has a colour
  const ReadResult result = read_off("pyramid.off", text);
  const auto& mesh = std::get<TriangleMesh>(result.model);
  Triangles faces(3, 3);
  faces << 0, 1, 2, 0, 2, 3, 0, 1, 4;
  EXPECT_EQ(mesh.vertices.rows(), 5);
  EXPECT_EQ(mesh.faces, faces);
  EXPECT_EQ(result.report.polygons_triangulated, 1U);
  EXPECT_EQ(result.report.faces_read, 3U);
}

TEST(Off, NoffGivesNormalsAndCoffColoursAreSkipped) {
  const auto noff = read_off("n.off", "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n");
  EXPECT_EQ(std::get<TriangleMesh>(noff.model).vertex_normals.row(1), Eigen::RowVector3d(0, 0, 1));
  const auto coff = read_off("c.off", "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0\n0 1 0 1 1 1 1\n3 0 1 2\n");
  EXPECT_EQ(std::get<TriangleMesh>(coff.model).vertices.row(2), Eigen::RowVector3d(0, 1, 0));
}

TEST(Off, NoFacesIsACloud) {
  const ReadResult result = read_off("points.off", "OFF\n2 0 0\n1 2 3\n4 5 6\n");
  ASSERT_TRUE(std::holds_alternative<PointCloud>(result.model));
  EXPECT_EQ(std::get<PointCloud>(result.model).points.rows(), 2);
}

TEST(Off, WritesCountsThenVerticesThenFaces) {
  TriangleMesh mesh;
  mesh.vertices.resize(3, 3);
  mesh.vertices << 0, 0, 0, 1, 0, 0, 0, 1, 0.5;
  mesh.faces.resize(1, 3);
  mesh.faces << 0, 1, 2;
  std::ostringstream out;
  write_off(out, mesh);
  EXPECT_EQ(out.str(), "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0.5\n3 0 1 2\n");
}

}  // namespace
}  // namespace cmm::geometry
