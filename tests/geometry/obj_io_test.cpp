// OBJ specifics: every corner form, relative indices, ignored statements, normals, clouds.
#include "geometry/obj_io.hpp"

#include <gtest/gtest.h>

#include <sstream>
#include <string>

namespace cmm::geometry {
namespace {

TEST(Obj, ReadsEveryCornerFormAndIgnoresOtherStatements) {
  const std::string text =
      "# exported by hand\nmtllib part.mtl\no part\ng top\ns 1\nusemtl steel\n"
      "v 0 0 0\nv 1 0 0\nv 1 1 0 1.0\nv 0 1 0\nv 0.5 0.5 1\n"
      "vt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n"
      "f 1 2 3\n"
      "f 1/1 3/3 4/2\n"
      "f 1//1 2//1 5//1\n"
      "f -5/1/1 -4/2/1 -3/3/1 -2/1/1\n";  // a quad by relative indices
  const ReadResult result = read_obj("part.obj", text);
  const auto& mesh = std::get<TriangleMesh>(result.model);
  Triangles faces(5, 3);
  faces << 0, 1, 2, 0, 2, 3, 0, 1, 4, 0, 1, 2, 0, 2, 3;
  EXPECT_EQ(mesh.vertices.rows(), 5);
  EXPECT_EQ(mesh.faces, faces);
  EXPECT_EQ(result.report.faces_read, 5U);
  EXPECT_EQ(result.report.polygons_triangulated, 1U);
  EXPECT_EQ(mesh.vertex_normals.rows(), 5);  // every vertex got normal 1 from some corner
}

TEST(Obj, CornerNormalsBecomeVertexNormals) {
  const std::string text =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\n"
      "f 1//1 2//1 3//1\nf 1//2 3//2 2//2\n";  // a second normal for the same vertex: the first wins
  const auto& result = read_obj("sheet.obj", text);
  const auto& mesh = std::get<TriangleMesh>(result.model);
  ASSERT_EQ(mesh.vertex_normals.rows(), 3);
  EXPECT_EQ(mesh.vertex_normals.row(2), Eigen::RowVector3d(0, 0, 1));
}

TEST(Obj, OnlyVerticesIsACloud) {
  const ReadResult result = read_obj("scan.obj", "v 1 2 3\nvn 0 0 1\nv 4 5 6\nvn 0 1 0\n");
  ASSERT_TRUE(std::holds_alternative<PointCloud>(result.model));
  const auto& cloud = std::get<PointCloud>(result.model);
  EXPECT_EQ(cloud.points.rows(), 2);
  EXPECT_EQ(cloud.normals.row(1), Eigen::RowVector3d(0, 1, 0));
}

TEST(Obj, WritesOneBasedFaces) {
  TriangleMesh mesh;
  mesh.vertices.resize(3, 3);
  mesh.vertices << 0, 0, 0, 1, 0, 0, 0, 1, 0.5;
  mesh.faces.resize(1, 3);
  mesh.faces << 0, 1, 2;
  std::ostringstream out;
  write_obj(out, mesh);
  EXPECT_EQ(out.str(), "v 0 0 0\nv 1 0 0\nv 0 1 0.5\nf 1 2 3\n");
}

}  // namespace
}  // namespace cmm::geometry
