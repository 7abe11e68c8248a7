// PLY specifics: the same model in all three encodings (big endian built here by hand, as we do not
// write it), unknown elements and properties skipped, polygons fanned, clouds read as clouds.
#include "geometry/ply_io.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "geometry/file_error.hpp"

namespace cmm::geometry {
namespace {

using ::testing::HasSubstr;

// One value of an element instance, with its PLY type, so a body can be rendered in any encoding.
struct Value {
  enum Type { uchar, int16, int32, uint32, float32, float64 } type;
  double value;
};
using Record = std::vector<Value>;

template <class T>
void put(std::string& out, double value, bool big_endian) {
  const T typed = static_cast<T>(value);
  char raw[sizeof(T)];
  std::memcpy(raw, &typed, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(raw, raw + sizeof(T));
  out.append(raw, sizeof(T));
}

std::string render(const std::string& format, const std::vector<Record>& records) {
  std::string out;
  const bool big_endian = format == "binary_big_endian";
  for (const Record& record : records) {
    for (const Value& v : record) {
      if (format == "ascii") {
        std::ostringstream text;
        text << v.value;
        if (&v != &record.front()) out += ' ';
        out += text.str();
        continue;
      }
      switch (v.type) {
        case Value::uchar:
          put<std::uint8_t>(out, v.value, big_endian);
          break;
        case Value::int16:
          put<std::int16_t>(out, v.value, big_endian);
          break;
        case Value::int32:
          put<std::int32_t>(out, v.value, big_endian);
          break;
        case Value::uint32:
          put<std::uint32_t>(out, v.value, big_endian);
          break;
        case Value::float32:
          put<float>(out, v.value, big_endian);
          break;
        case Value::float64:
          put<double>(out, v.value, big_endian);
          break;
      }
    }
    if (format == "ascii") out += '\n';
  }
  return out;
}

// A quad and a triangle over four vertices of mixed coordinate types, with a range_grid element (a
// list named like the face corners) between vertices and faces, and properties to skip everywhere.
std::string awkward_model(const std::string& format) {
  const std::string header = "ply\nformat " + format +
                             " 1.0\n"
                             "comment made by hand\nobj_info scanner 7\n"
                             "element vertex 4\n"
                             "property double x\nproperty float y\nproperty int z\nproperty uchar red\n"
                             "property list uchar float curvature\n"
                             "element range_grid 3\nproperty list uchar int vertex_indices\n"
                             "element face 2\n"
                             "property uchar flags\nproperty list uchar uint vertex_index\n"
                             "property list int short texnumber\n"
                             "end_header\n";
  using V = Value;
  const std::vector<Record> body = {
      {{V::float64, 0.25}, {V::float32, 0}, {V::int32, -3}, {V::uchar, 255}, {V::uchar, 1}, {V::float32, 0.5}},
      {{V::float64, 1}, {V::float32, 0}, {V::int32, 0}, {V::uchar, 1}, {V::uchar, 0}},
      {{V::float64, 1},
       {V::float32, 1.5},
       {V::int32, 0},
       {V::uchar, 2},
       {V::uchar, 2},
       {V::float32, 1},
       {V::float32, 2}},
      {{V::float64, 0}, {V::float32, 1}, {V::int32, 1}, {V::uchar, 3}, {V::uchar, 1}, {V::float32, 3}},
      {{V::uchar, 1}, {V::int32, 0}},
      {{V::uchar, 0}},
      {{V::uchar, 2}, {V::int32, 1}, {V::int32, 2}},
      {{V::uchar, 7},
       {V::uchar, 4},
       {V::uint32, 0},
       {V::uint32, 1},
       {V::uint32, 2},
       {V::uint32, 3},
       {V::int32, 1},
       {V::int16, 9}},
      {{V::uchar, 0}, {V::uchar, 3}, {V::uint32, 3}, {V::uint32, 2}, {V::uint32, 1}, {V::int32, 0}},
  };
  return header + render(format, body);
}

TEST(Ply, EveryEncodingReadsTheSameModel) {
  for (const std::string format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    const ReadResult result = read_ply("awkward.ply", awkward_model(format));
    ASSERT_TRUE(std::holds_alternative<TriangleMesh>(result.model)) << format;
    const auto& mesh = std::get<TriangleMesh>(result.model);
    Points vertices(4, 3);
    vertices << 0.25, 0, -3, 1, 0, 0, 1, 1.5, 0, 0, 1, 1;
    Triangles faces(3, 3);
    faces << 0, 1, 2, 0, 2, 3, 3, 2, 1;
    EXPECT_EQ(mesh.vertices, vertices) << format;
    EXPECT_EQ(mesh.faces, faces) << format;
    EXPECT_EQ(mesh.vertex_normals.rows(), 0);
    EXPECT_EQ(result.report.vertices_read, 4U);
    EXPECT_EQ(result.report.faces_read, 3U);
    EXPECT_EQ(result.report.polygons_triangulated, 1U);
  }
}

TEST(Ply, PentagonIsFanTriangulated) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n2 1 0\n1 2 0\n0 1 0\n5 0 1 2 3 4\n";
  const ReadResult result = read_ply("pentagon.ply", text);
  Triangles fan(3, 3);
  fan << 0, 1, 2, 0, 2, 3, 0, 3, 4;
  EXPECT_EQ(std::get<TriangleMesh>(result.model).faces, fan);
  EXPECT_EQ(result.report.faces_read, 3U);
  EXPECT_EQ(result.report.polygons_triangulated, 1U);
}

TEST(Ply, FileWithoutFacesIsACloudWithNormals) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n";
  const std::string body = "end_header\n1 2 3 0 0 1\n4 5 6 1 0 0\n";
  for (const std::string faces : {"", "element face 0\nproperty list uchar int vertex_indices\n"}) {
    const ReadResult result = read_ply("scan.ply", header + faces + body);
    ASSERT_TRUE(std::holds_alternative<PointCloud>(result.model));
    const auto& cloud = std::get<PointCloud>(result.model);
    ASSERT_EQ(cloud.normals.rows(), 2);
    EXPECT_EQ(cloud.points.row(1), Eigen::RowVector3d(4, 5, 6));
    EXPECT_EQ(cloud.normals.row(1), Eigen::RowVector3d(1, 0, 0));
  }
}

TEST(Ply, AsciiOutputIsReadableByEye) {
  TriangleMesh mesh;
  mesh.vertices.resize(3, 3);
  mesh.vertices << 0, 0.1, -2.5e-7, 1000.0005, 0, 0, 0, 1, 0;
  mesh.faces.resize(1, 3);
  mesh.faces << 0, 1, 2;
  std::ostringstream out;
  write_ply(out, mesh, PlyEncoding::ascii);
  EXPECT_EQ(out.str(),
            "ply\nformat ascii 1.0\nelement vertex 3\n"
            "property double x\nproperty double y\nproperty double z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
            "0 0.1 -2.5e-07\n1000.0005 0 0\n0 1 0\n3 0 1 2\n");
}

TEST(Ply, BinaryOutputIsLittleEndianFloat64) {
  PointCloud cloud;
  cloud.points.resize(1, 3);
  cloud.points << 0.1, 0.2, 0.3;
  std::ostringstream out;
  write_ply(out, cloud);
  const std::string bytes = out.str();
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
      "property double x\nproperty double y\nproperty double z\nend_header\n";
  ASSERT_EQ(bytes.substr(0, header.size()), header);
  std::string expected;
  for (const double c : {0.1, 0.2, 0.3}) put<double>(expected, c, false);
  EXPECT_EQ(bytes.substr(header.size()), expected);
}

TEST(Ply, DataAfterTheLastElementIsAnError) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "end_header\n0 0 0\n1 1 1\n";
  try {
    read_ply("extra.ply", text);
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("extra.ply: line 9: data after the last element"));
  }
}

// Found by the ply fuzz target (tests/fuzz/corpus/ply/timeout-b7fb2c91…): a binary element without
// properties takes no bytes, so "element marker 666666666666660" kept the reader busy for ever.
TEST(Ply, AnElementWithInstancesButNoPropertiesIsAnError) {
  for (const char* format : {"binary_little_endian", "ascii"}) {
    const std::string text = std::string("ply\nformat ") + format +
                             " 1.0\nelement marker 3\nelement vertex 1\nproperty float x\nproperty float y\n"
                             "property float z\nend_header\n" +
                             (format[0] == 'a' ? std::string("0 0 0\n") : std::string(12, '\0'));
    try {
      read_ply("marker.ply", text);
      FAIL() << format << ": no error";
    } catch (const FileError& e) {
      EXPECT_THAT(e.what(), HasSubstr("marker.ply: line 3: element 'marker' has 3 instances but no properties"));
    }
  }
}

}  // namespace
}  // namespace cmm::geometry
