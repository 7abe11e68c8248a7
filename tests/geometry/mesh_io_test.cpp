// Reading and writing by extension: round trips through every format, the clean-up every mesh gets,
// and the one FileError, naming file and line or byte, that every broken file gives.
#include "geometry/mesh_io.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "geometry/file_error.hpp"
#include "geometry/mesh_cleanup.hpp"
#include "geometry/obj_io.hpp"
#include "geometry/off_io.hpp"
#include "geometry/ply_io.hpp"
#include "geometry/stl_io.hpp"
#include "geometry/xyz_io.hpp"

namespace cmm::geometry {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// Coordinates that float32 cannot hold, so a format that drops to float would show.
TriangleMesh cube(double size = 0.1, double offset = 1000.123) {
  TriangleMesh mesh;
  mesh.vertices.resize(8, 3);
  mesh.vertices << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  mesh.vertices = (mesh.vertices.array() * size + offset).matrix();
  mesh.faces.resize(12, 3);
  mesh.faces << 0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 2, 3, 7, 2, 7, 6, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6,
      5;
  return mesh;
}

PointCloud cloud(bool with_normals) {
  PointCloud cloud;
  cloud.points.resize(3, 3);
  cloud.points << 0.1, -2.5e-7, 3, 1e6 / 3, 0, -0.3, 7, 8, 9;
  if (with_normals) {
    cloud.normals.resize(3, 3);
    cloud.normals << 0, 0, 1, 0.6, 0.8, 0, -1, 0, 0;
  }
  return cloud;
}

// Eigen's == asserts equal sizes; this checks them first and prints both on failure.
template <class A, class B>
::testing::AssertionResult same(const A& a, const B& b) {
  if (a.rows() == b.rows() && a.cols() == b.cols() && a == b) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "\n" << a << "\n  differs from\n" << b;
}

class MeshIo : public ::testing::Test {
 protected:
  void SetUp() override { fs::create_directories(dir_); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path path(const std::string& name) const { return dir_ / name; }

 private:
  fs::path dir_ = fs::path(::testing::TempDir()) / ("cmmd_mesh_io_" + std::to_string(::getpid()));
};

TEST_F(MeshIo, MeshRoundTripsExactlyThroughPlyObjOff) {
  TriangleMesh mesh = cube();
  for (const bool with_normals : {false, true}) {
    if (with_normals) mesh.vertex_normals = mesh.vertices.rowwise().normalized();
    for (const std::string extension : {".ply", ".obj", ".off"}) {
      const fs::path file = path("cube" + extension);
      write_mesh(file, mesh);
      ReadReport report;
      const TriangleMesh read = read_mesh(file, &report);
      EXPECT_TRUE(same(read.vertices, mesh.vertices)) << file;
      EXPECT_TRUE(same(read.faces, mesh.faces)) << file;
      EXPECT_TRUE(same(read.vertex_normals, mesh.vertex_normals)) << file;
      EXPECT_EQ(report.vertices_read, 8U);
      EXPECT_EQ(report.faces_read, 12U);
    }
  }
}

TEST_F(MeshIo, AsciiPlyRoundTripsExactly) {
  const TriangleMesh mesh = cube();
  const fs::path file = path("cube_ascii.ply");
  {
    std::ofstream out(file, std::ios::binary);
    write_ply(out, mesh, PlyEncoding::ascii);
  }
  const TriangleMesh read = read_mesh(file);
  EXPECT_TRUE(same(read.vertices, mesh.vertices));
  EXPECT_TRUE(same(read.faces, mesh.faces));
}

TEST_F(MeshIo, StlRoundTripKeepsEveryFacetOnFloatCoordinates) {
  const TriangleMesh mesh = cube(2.5, -10);  // float32-exact
  const fs::path file = path("cube.stl");
  write_mesh(file, mesh);
  ReadReport report;
  const TriangleMesh read = read_mesh(file, &report);
  ASSERT_EQ(read.vertices.rows(), 8);
  ASSERT_EQ(read.faces.rows(), 12);
  // Welding renumbers vertices in order of first use, so compare the facets' corners.
  for (int f = 0; f < 12; ++f) {
    for (int k = 0; k < 3; ++k) EXPECT_EQ(vertex(read, read.faces(f, k)), vertex(mesh, mesh.faces(f, k)));
  }
  EXPECT_EQ(report.vertices_read, 36U);
  EXPECT_EQ(report.vertices_welded, 28U);
}

TEST_F(MeshIo, CloudRoundTripsExactlyThroughPlyObjOffXyz) {
  for (const bool with_normals : {false, true}) {
    const PointCloud original = cloud(with_normals);
    for (const std::string extension : {".ply", ".obj", ".off", ".xyz"}) {
      const fs::path file = path("cloud" + extension);
      write_cloud(file, original);
      const ReadResult result = read_model(file);
      ASSERT_TRUE(std::holds_alternative<PointCloud>(result.model)) << file;
      const auto& read = std::get<PointCloud>(result.model);
      EXPECT_TRUE(same(read.points, original.points)) << file;
      EXPECT_TRUE(same(read.normals, original.normals)) << file;
      EXPECT_EQ(result.report.vertices_read, 3U);
    }
  }
}

TEST_F(MeshIo, ExtensionIsCaseInsensitive) {
  const fs::path file = path("CUBE.Ply");
  write_mesh(file, cube());
  EXPECT_EQ(read_mesh(file).faces.rows(), 12);
}

TEST_F(MeshIo, UnknownExtensionNamesTheSupportedOnes) {
  try {
    read_model(path("part.step"));
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("part.step"));
    EXPECT_THAT(e.what(), HasSubstr("'.step'; expected .stl, .ply, .obj, .off, .xyz, .asc or .pcd"));
  }
  EXPECT_THROW(write_mesh(path("part"), cube()), FileError);
}

TEST_F(MeshIo, ReadMeshRefusesACloud) {
  const fs::path file = path("points.xyz");
  write_cloud(file, cloud(false));
  try {
    read_mesh(file);
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("points.xyz: holds a point cloud (3 points, no faces)"));
  }
}

TEST_F(MeshIo, FormatsRefuseWhatTheyCannotHold) {
  EXPECT_THROW(write_mesh(path("cube.xyz"), cube()), FileError);
  EXPECT_THROW(write_cloud(path("points.stl"), cloud(false)), FileError);
  EXPECT_FALSE(fs::exists(path("cube.xyz")));
}

TEST_F(MeshIo, MissingFileNamesTheSystemError) {
  try {
    read_model(path("absent.stl"));
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("absent.stl: cannot open: No such file or directory"));
  }
}

TEST_F(MeshIo, EmptyFileHoldsNoVertices) {
  std::ofstream(path("empty.xyz")) << "# nothing here\n";
  EXPECT_THROW(read_model(path("empty.xyz")), FileError);
}

TEST_F(MeshIo, ReaderDropsDegenerateAndDuplicateFacesAndCountsThem) {
  std::ofstream(path("dirty.obj")) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n"
                                      "f 1 2 3\n"
                                      "f 1 1 3\n"  // repeated index
                                      "f 1 2 5\n"  // collinear: zero area
                                      "f 2 3 1\n"  // duplicate, rotated
                                      "f 3 2 1\n"  // duplicate, flipped
                                      "f 1 3 4\n";
  ReadReport report;
  const TriangleMesh mesh = read_mesh(path("dirty.obj"), &report);
  EXPECT_EQ(report.faces_read, 6U);
  EXPECT_EQ(report.degenerate_faces_dropped, 2U);
  EXPECT_EQ(report.duplicate_faces_dropped, 2U);
  ASSERT_EQ(mesh.faces.rows(), 2);
  EXPECT_EQ(mesh.faces.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(mesh.faces.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(mesh.vertices.rows(), 5);  // unreferenced vertex 5 stays: indices are the file's
}

TEST(MeshIoCleanup, WeldMergesNearPointsAcrossCellBorders) {
  // 1000 random points, each repeated at a random offset of half the tolerance: many pairs straddle
  // a grid-cell border, and all must merge; points a hundred tolerances apart must not.
  TriangleMesh mesh;
  const int n = 1000;
  Points base = Points::Random(n, 3);
  const double tolerance = relative_tolerance * (base.colwise().maxCoeff() - base.colwise().minCoeff()).norm();
  mesh.vertices.resize(2 * n, 3);
  mesh.vertices.topRows(n) = base;
  const Points directions = Points::Random(n, 3);  // evaluated once: Random redraws on every read
  mesh.vertices.bottomRows(n) = base + directions.rowwise().normalized() * (0.5 * tolerance);
  mesh.faces.resize(1, 3);
  mesh.faces << 0, n, 1;
  ReadReport report;
  weld_vertices(mesh, report);
  EXPECT_EQ(report.vertices_welded, static_cast<std::size_t>(n));
  EXPECT_TRUE(same(mesh.vertices, base));
  EXPECT_EQ(mesh.faces.row(0), Eigen::RowVector3i(0, 0, 1));

  TriangleMesh apart;
  apart.vertices.resize(3, 3);
  apart.vertices << 0, 0, 0, 100 * relative_tolerance, 0, 0, 1, 0, 0;
  weld_vertices(apart, report);
  EXPECT_EQ(apart.vertices.rows(), 3);
}

struct BrokenFile {
  std::string name;
  std::string where;    // "line N" or "byte N"
  std::string message;  // a telling part of what is wrong
};

TEST(MeshIoBrokenFiles, EachGivesOneFileErrorNamingFileAndLocation) {
  const std::vector<BrokenFile> cases = {
      {"truncated.stl", "byte 134", "truncated: header announces 2 facets (184 bytes) but the file has 154 bytes"},
      {"count_mismatch.stl", "byte 80", "header announces 1 facets (134 bytes) but the file has 184 bytes"},
      {"bad_keyword.stl", "line 9", "expected 'facet' or 'endsolid', got 'facett'"},
      {"missing_endloop.stl", "line 14", "expected 'endloop', got 'endfacet'"},
      {"nan.stl", "line 5", "'nan' is not a finite number"},
      {"inf.stl", "byte 134", "facet 1 has a non-finite coordinate (inf)"},
      {"bad_magic.ply", "line 1", "bad magic"},
      {"unknown_format.ply", "line 2", "unknown format 'binary_middle_endian'"},
      {"missing_end_header.ply", "line 7", "unexpected '0' in the header"},
      {"truncated.ply", "byte 205", "truncated: face 0 runs past the end of the file (214 bytes)"},
      {"face_index_out_of_range.ply", "line 16", "face 1 has vertex index 7, but the file has 4 vertices"},
      {"vertex_count_too_large.ply", "line 3", "header announces 10 vertex elements but the file ends after 4"},
      {"bad_property_type.ply", "line 6", "unknown property type 'float3'"},
      {"nan.ply", "line 10", "vertex 2 has a non-finite value (nan)"},
      {"inf.ply", "byte 139", "vertex 2 has a non-finite value (-inf)"},
      {"face_index_out_of_range.obj", "line 7", "face has vertex index 9, but the file has 4 vertices"},
      {"non_numeric.obj", "line 4", "'x' is not an integer"},
      {"nan.obj", "line 2", "'nan' is not a finite number"},
      {"inf.obj", "line 4", "'inf' is not a finite number"},
      {"wrong_counts.off", "line 7", "vertex 4 has 4 values; expected x y z"},
      {"missing_header.off", "line 1", "missing header: expected OFF"},
      {"face_index_out_of_range.off", "line 9", "face 1 has vertex index 4, but the file has 4 vertices"},
      {"nan.off", "line 4", "'nan' is not a finite number"},
      {"inf.off", "line 5", "'-inf' is not a finite number"},
      {"two_columns.xyz", "line 3", "2 values; expected 'x y z' or 'x y z nx ny nz'"},
      {"garbage.xyz", "line 3", "'abc' is not a number"},
      {"nan.xyz", "line 3", "'nan' is not a finite number"},
      {"inf.xyz", "line 3", "'inf' is not a finite number"},
  };
  for (const BrokenFile& broken : cases) {
    const fs::path file = fs::path(CMMD_TEST_DATA_DIR) / "broken" / broken.name;
    ASSERT_TRUE(fs::exists(file)) << file;
    try {
      read_model(file);
      ADD_FAILURE() << broken.name << ": no error";
    } catch (const FileError& e) {
      EXPECT_THAT(e.what(), HasSubstr(file.string() + ": " + broken.where + ": " + broken.message));
    }
  }
}

TEST(MeshIoRobustness, EveryTruncationAndCorruptionGivesAModelOrAFileError) {
  // Valid files of every format and encoding, cut at every length and with every byte overwritten by a
  // few telling values: the readers must never read out of bounds (run under ASan) or throw anything
  // but a FileError.
  using Reader = ReadResult (*)(const fs::path&, std::string_view);
  const TriangleMesh mesh = cube();
  const PointCloud points = cloud(true);
  std::vector<std::pair<Reader, std::string>> files;
  const auto add = [&](Reader read, const auto& write) {
    std::ostringstream out;
    write(out);
    files.emplace_back(read, out.str());
  };
  add(read_stl, [&](std::ostream& out) { write_stl(out, mesh); });
  add(read_ply, [&](std::ostream& out) { write_ply(out, mesh); });
  add(read_ply, [&](std::ostream& out) { write_ply(out, mesh, PlyEncoding::ascii); });
  add(read_ply, [&](std::ostream& out) { write_ply(out, points); });
  add(read_obj, [&](std::ostream& out) { write_obj(out, mesh); });
  add(read_off, [&](std::ostream& out) { write_off(out, mesh); });
  add(read_xyz, [&](std::ostream& out) { write_xyz(out, points); });
  files.emplace_back(read_stl,
                     "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                     "endloop\nendfacet\nendsolid t\n");

  std::size_t errors = 0;
  for (const auto& [read, bytes] : files) {
    std::vector<std::string> variants;
    for (std::size_t cut = 0; cut < bytes.size(); ++cut) variants.push_back(bytes.substr(0, cut));
    for (std::size_t at = 0; at < bytes.size(); ++at) {
      for (const char c : {'\0', '\n', ' ', '9', '-', '\xff'}) {
        variants.push_back(bytes);
        variants.back()[at] = c;
      }
    }
    for (const std::string& variant : variants) {
      try {
        read("fuzzed", variant);
      } catch (const FileError&) {
        ++errors;
      }
    }
  }
  EXPECT_GT(errors, 0U);
}

}  // namespace
}  // namespace cmm::geometry
