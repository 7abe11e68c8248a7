// STL specifics: welding the facet soup, telling binary from ASCII, ignoring the stored normals.
#include "geometry/stl_io.hpp"

#include <gtest/gtest.h>

#include <sstream>
#include <string>

namespace cmm::geometry {
namespace {

// A unit cube as 12 ASCII facets: 36 corners, 8 distinct points.
std::string cube_stl(const std::string& normal = "0 0 0") {
  const int faces[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                            {2, 3, 7}, {2, 7, 6}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
  const char* corners[8] = {"0 0 0", "1 0 0", "1 1 0", "0 1 0", "0 0 1", "1 0 1", "1 1 1", "0 1 1"};
  std::string text = "solid cube\n";
  for (const auto& face : faces) {
    text += "facet normal " + normal + "\n outer loop\n";
    for (const int v : face) text += "  vertex " + std::string(corners[v]) + "\n";
    text += " endloop\nendfacet\n";
  }
  return text + "endsolid cube\n";
}

std::string binary(const TriangleMesh& mesh) {
  std::ostringstream out;
  write_stl(out, mesh);
  return out.str();
}

TEST(Stl, CubeSoupWeldsToEightVertices) {
  const ReadResult result = read_stl("cube.stl", cube_stl());
  const auto& mesh = std::get<TriangleMesh>(result.model);
  EXPECT_EQ(mesh.vertices.rows(), 8);
  EXPECT_EQ(mesh.faces.rows(), 12);
  EXPECT_EQ(result.report.vertices_read, 36U);
  EXPECT_EQ(result.report.faces_read, 12U);
  EXPECT_EQ(result.report.vertices_welded, 28U);
  // Kept vertices are numbered in order of first use.
  EXPECT_EQ(mesh.faces.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(vertex(mesh, 1), Vec3(1, 1, 0));
}

TEST(Stl, BinaryCubeWeldsTheSame) {
  const TriangleMesh ascii = std::get<TriangleMesh>(read_stl("cube.stl", cube_stl()).model);
  const ReadResult result = read_stl("cube.stl", binary(ascii));
  const auto& mesh = std::get<TriangleMesh>(result.model);
  EXPECT_EQ(mesh.vertices, ascii.vertices);
  EXPECT_EQ(mesh.faces, ascii.faces);
  EXPECT_EQ(result.report.vertices_welded, 28U);
}

TEST(Stl, BinaryHeaderStartingWithSolidIsStillBinary) {
  const TriangleMesh cube = std::get<TriangleMesh>(read_stl("cube.stl", cube_stl()).model);
  std::string bytes = binary(cube);
  const std::string header = "solid cube exported by a CAD system that should know better";
  bytes.replace(0, header.size(), header);
  const TriangleMesh mesh = std::get<TriangleMesh>(read_stl("cube.stl", bytes).model);
  EXPECT_EQ(mesh.faces.rows(), 12);
  EXPECT_EQ(mesh.vertices, cube.vertices);
}

TEST(Stl, FileNormalsAreIgnoredAndWindingKept) {
  const TriangleMesh ignored = std::get<TriangleMesh>(read_stl("cube.stl", cube_stl("0 0 1")).model);
  const TriangleMesh zero = std::get<TriangleMesh>(read_stl("cube.stl", cube_stl()).model);
  EXPECT_EQ(ignored.faces, zero.faces);
  EXPECT_EQ(ignored.vertex_normals.rows(), 0);
}

TEST(Stl, NearCornersWeldAndDistantOnesDoNot) {
  // The bbox diagonal is about 1.4, so the tolerance is about 1.4e-6.
  const std::string text =
      "solid s\n"
      "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nendloop\nendfacet\n"
      "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1.0000005 1 0\nvertex 0 1.00001 0\nendloop\nendfacet\n"
      "endsolid s\n";
  const ReadResult result = read_stl("near.stl", text);
  const auto& mesh = std::get<TriangleMesh>(result.model);
  EXPECT_EQ(mesh.vertices.rows(), 4);
  EXPECT_EQ(result.report.vertices_welded, 2U);
  EXPECT_EQ(mesh.faces.row(1), Eigen::RowVector3i(0, 2, 3));
}

TEST(Stl, SeveralSolidsInOneFile) {
  const std::string one = cube_stl();
  const TriangleMesh mesh = std::get<TriangleMesh>(read_stl("two.stl", one + one).model);
  EXPECT_EQ(mesh.vertices.rows(), 8);
  EXPECT_EQ(mesh.faces.rows(), 24);  // the duplicates go in read_model's clean-up
}

}  // namespace
}  // namespace cmm::geometry
