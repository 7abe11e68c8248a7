// PCD specifics: the same cloud in all three encodings (binary_compressed built here, and one file
// made by PCL itself), any field order and type, fields skipped, organized clouds with missing
// returns, VIEWPOINT, and every malformed header or body refused naming its line or byte.
#include "geometry/pcd_io.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "geometry/file_error.hpp"
#include "geometry/lzf.hpp"
#include "geometry/mesh_io.hpp"

namespace cmm::geometry {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using namespace std::string_literals;

// A PCD field as the header declares it.
struct Field {
  std::string name;
  int size;
  char type;
  int count = 1;
};

template <class T>
void put(std::string& out, double value) {
  const T typed = static_cast<T>(value);
  char raw[sizeof(T)];
  std::memcpy(raw, &typed, sizeof(T));
  out.append(raw, sizeof(T));
}

void put_value(std::string& out, const Field& f, double value) {
  if (f.type == 'F') return f.size == 4 ? put<float>(out, value) : put<double>(out, value);
  if (f.type == 'I') {
    if (f.size == 1) return put<std::int8_t>(out, value);
    if (f.size == 2) return put<std::int16_t>(out, value);
    if (f.size == 4) return put<std::int32_t>(out, value);
    return put<std::int64_t>(out, value);
  }
  if (f.size == 1) return put<std::uint8_t>(out, value);
  if (f.size == 2) return put<std::uint16_t>(out, value);
  if (f.size == 4) return put<std::uint32_t>(out, value);
  put<std::uint64_t>(out, value);
}

// LZF of literal runs only: valid LZF (what PCL's decoder and ours read) without the compression.
std::string lzf_literals(const std::string& bytes) {
  std::string out;
  for (std::size_t at = 0; at < bytes.size(); at += 32) {
    const std::size_t n = std::min<std::size_t>(32, bytes.size() - at);
    out += static_cast<char>(n - 1);
    out.append(bytes, at, n);
  }
  return out;
}

std::string u32(std::uint32_t v) {
  std::string out;
  put<std::uint32_t>(out, v);
  return out;
}

struct Cloud {
  std::vector<Field> fields;
  std::vector<std::vector<double>> points;  // each: every field's values in field order
  std::size_t width = 0, height = 1;
  std::string viewpoint = "0 0 0 1 0 0 0";

  std::string header(const std::string& data) const {
    std::string names, sizes, types, counts;
    for (const Field& f : fields) {
      // Appended piecewise: GCC 12 at -O3 warns falsely (-Wrestrict) on "literal" + std::string&&.
      names.append(" ").append(f.name);
      sizes.append(" ").append(std::to_string(f.size));
      types.append(" ").push_back(f.type);
      counts.append(" ").append(std::to_string(f.count));
    }
    const std::size_t w = width ? width : points.size();
    return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS" + names + "\nSIZE" + sizes + "\nTYPE" +
           types + "\nCOUNT" + counts + "\nWIDTH " + std::to_string(w) + "\nHEIGHT " + std::to_string(height) +
           "\nVIEWPOINT " + viewpoint + "\nPOINTS " + std::to_string(points.size()) + "\nDATA " + data + "\n";
  }

  std::string render(const std::string& data) const {
    std::string out = header(data);
    if (data == "ascii") {
      for (const auto& p : points) {
        for (std::size_t k = 0; k < p.size(); ++k) {
          std::ostringstream text;
          text.precision(17);
          text << p[k];
          if (k) out += ' ';
          out += text.str();
        }
        out += '\n';
      }
      return out;
    }
    // Records for binary; field columns, one after the other, for binary_compressed.
    std::string body;
    if (data == "binary") {
      for (const auto& p : points) {
        std::size_t k = 0;
        for (const Field& f : fields)
          for (int c = 0; c < f.count; ++c) put_value(body, f, p[k++]);
      }
      return out + body;
    }
    std::size_t first = 0;
    for (const Field& f : fields) {
      for (const auto& p : points)
        for (int c = 0; c < f.count; ++c) put_value(body, f, p[first + static_cast<std::size_t>(c)]);
      first += static_cast<std::size_t>(f.count);
    }
    const std::string block = lzf_literals(body);
    return out + u32(static_cast<std::uint32_t>(block.size())) + u32(static_cast<std::uint32_t>(body.size())) + block;
  }
};

const std::vector<std::string> encodings = {"ascii", "binary", "binary_compressed"};

PointCloud cloud_of(const ReadResult& result) { return std::get<PointCloud>(result.model); }

std::string error_of(const std::string& bytes) {
  try {
    read_pcd("bad.pcd", bytes);
  } catch (const FileError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Pcd, ReadsEveryEncodingWithFieldsInAnyOrderAndOthersSkipped) {
  // Normals before the coordinates, padding, a 4-value descriptor, colour and intensity between them,
  // coordinates of three types.
  Cloud c;
  c.fields = {{"rgb", 4, 'U'},      {"normal_z", 4, 'F'}, {"x", 8, 'F'},        {"_", 1, 'U', 3},
              {"intensity", 2, 'I'}, {"y", 4, 'F'},        {"normal_x", 4, 'F'}, {"fpfh", 4, 'F', 4},
              {"z", 2, 'I'},         {"normal_y", 4, 'F'}};
  c.points = {{0xff0000, 1, 0.1, 0, 0, 0, -7, 2.5, 0, 1, 2, 3, 4, -3, 0},
              {0x00ff00, 0, -1e-3, 1, 2, 3, 300, -0.5, 0.625, 0, 0, 0, 0, 12, 0.75}};
  for (const std::string& data : encodings) {
    const ReadResult result = read_pcd("fields.pcd", c.render(data));
    const PointCloud cloud = cloud_of(result);
    Points points(2, 3), normals(2, 3);
    points << 0.1, 2.5, -3, -1e-3, -0.5, 12;
    normals << 0, 0, 1, 0.625, 0.75, 0;
    EXPECT_EQ(cloud.points, points) << data;
    EXPECT_EQ(cloud.normals, normals) << data;
    EXPECT_EQ(result.report.vertices_read, 2U);
    EXPECT_EQ(result.report.points_without_return, 0U);
    EXPECT_FALSE(result.report.viewpoint_applied);
  }
}

TEST(Pcd, IntegerCoordinatesOfEveryWidth) {
  Cloud c;
  c.fields = {{"x", 1, 'I'}, {"y", 8, 'U'}, {"z", 4, 'I'}, {"w", 8, 'I'}};
  c.points = {{-128, 1e15, -2e9, -5}};
  for (const std::string& data : encodings) EXPECT_EQ(cloud_of(read_pcd("int.pcd", c.render(data))).points,
                                                      Eigen::RowVector3d(-128, 1e15, -2e9)) << data;
}

TEST(Pcd, APartialNormalIsNoNormal) {
  Cloud c;
  c.fields = {{"x", 4, 'F'}, {"y", 4, 'F'}, {"z", 4, 'F'}, {"normal_x", 4, 'F'}, {"normal_y", 4, 'F'}};
  c.points = {{1, 2, 3, std::nan(""), 0}};
  EXPECT_EQ(cloud_of(read_pcd("partial.pcd", c.render("ascii"))).normals.rows(), 0);
}

TEST(Pcd, RoundTripsThroughTheWriter) {
  PointCloud original;
  original.points.resize(3, 3);
  original.points << 0.1, -2.5e-7, 3, 1e6 / 3, 0, -0.3, 1000.123, 8, 9;
  for (const bool with_normals : {false, true}) {
    original.normals.resize(with_normals ? 3 : 0, 3);
    if (with_normals) original.normals << 0, 0, 1, 0.6, 0.8, 0, -1, 0, 0;
    for (const PcdEncoding encoding : {PcdEncoding::ascii, PcdEncoding::binary}) {
      std::ostringstream exact, narrow;
      write_pcd(exact, original, encoding, PcdScalar::float64);
      write_pcd(narrow, original, encoding, PcdScalar::float32);
      const PointCloud read = cloud_of(read_pcd("exact.pcd", exact.str()));
      EXPECT_EQ(read.points, original.points);
      EXPECT_EQ(read.normals, original.normals);
      // float32 is what PCL's point types hold: each value to the nearest float (in ASCII too: a
      // field of TYPE F, SIZE 4 reads as a float, as PCL reads it).
      const PointCloud read32 = cloud_of(read_pcd("narrow.pcd", narrow.str()));
      EXPECT_EQ(read32.points, original.points.cast<float>().cast<double>());
      EXPECT_EQ(read32.normals, original.normals.cast<float>().cast<double>());
    }
  }
}

TEST(Pcd, WritesPclsHeader) {
  PointCloud cloud;
  cloud.points.resize(1, 3);
  cloud.points << 1, 2, 3;
  cloud.normals.resize(1, 3);
  cloud.normals << 0, 0, 1;
  std::ostringstream out;
  write_pcd(out, cloud, PcdEncoding::ascii);
  EXPECT_EQ(out.str(),
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z normal_x normal_y normal_z\n"
            "SIZE 4 4 4 4 4 4\nTYPE F F F F F F\nCOUNT 1 1 1 1 1 1\nWIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
            "POINTS 1\nDATA ascii\n1 2 3 0 0 1\n");
}

TEST(Pcd, FilesPclWroteReadTheSame) {
  // tests/data/pcd: a hand-written ASCII cloud with normals and curvature, and PCL's binary and
  // binary_compressed of it (pcl_convert_pcd_ascii_binary, Debian pcl-tools 1.13: tests/data/README.md).
  const fs::path dir = fs::path(CMMD_TEST_DATA_DIR) / "pcd";
  const ReadResult ascii = read_model(dir / "plane_normals_ascii.pcd");
  const ReadResult binary = read_model(dir / "plane_normals_binary.pcd");  // PCL pads it with a page of zeros
  const ReadResult compressed = read_model(dir / "plane_normals_binary_compressed.pcd");
  const PointCloud a = cloud_of(ascii), b = cloud_of(binary), c = cloud_of(compressed);
  ASSERT_EQ(a.points.rows(), 48);
  ASSERT_EQ(a.normals.rows(), 48);
  EXPECT_EQ(b.points, c.points);
  EXPECT_EQ(b.normals, c.normals);
  EXPECT_EQ(b.points, a.points);  // ASCII floats read as floats too
  EXPECT_EQ(b.normals, a.normals);
  EXPECT_EQ(a.points.row(47), Eigen::RowVector3d(8.75, 3.75, static_cast<float>(0.05 * 8.75 * 8.75 - 0.375)));
}

TEST(Pcd, OrganizedCloudDropsPixelsWithoutAReturn) {
  Cloud c;
  c.fields = {{"x", 4, 'F'}, {"y", 4, 'F'}, {"z", 4, 'F'}, {"rgb", 4, 'F'}};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  c.points = {{0, 0, 1, 0}, {nan, nan, nan, 0}, {1, 1, 1, nan}, {nan, nan, nan, nan}, {2, 0, 1, 0}, {0, 2, 1, 0}};
  c.width = 3;
  c.height = 2;
  for (const std::string& data : encodings) {
    const ReadResult result = read_pcd("organized.pcd", c.render(data));
    Points points(4, 3);
    points << 0, 0, 1, 1, 1, 1, 2, 0, 1, 0, 2, 1;
    EXPECT_EQ(cloud_of(result).points, points) << data;
    EXPECT_EQ(result.report.vertices_read, 4U);
    EXPECT_EQ(result.report.points_without_return, 2U);
  }
  // The same NaN in one row is a broken file, not a missing return.
  c.width = 0;
  c.height = 1;
  EXPECT_THAT(error_of(c.render("ascii")),
              HasSubstr("bad.pcd: line 13: point 1 has x nan (NaN marks a missing return only in an organized cloud"));
  EXPECT_THAT(error_of(c.render("binary")), HasSubstr("bad.pcd: byte " + std::to_string(c.header("binary").size() + 16) +
                                                      ": point 1 has x nan"));
}

TEST(Pcd, ViewpointPlacesTheSensorFramesPoints) {
  Cloud c;
  c.fields = {{"x", 8, 'F'}, {"y", 8, 'F'}, {"z", 8, 'F'}, {"normal_x", 8, 'F'}, {"normal_y", 8, 'F'}, {"normal_z", 8, 'F'}};
  c.points = {{1, 0, 0, 1, 0, 0}, {0, 2, 3, 0, 1, 0}};
  // A quarter turn about z (qw = qz = √½, given unnormalized: it is normalized) and then a shift.
  c.viewpoint = "10 20 30 2 0 0 2";
  const ReadResult result = read_pcd("view.pcd", c.render("binary"));
  const PointCloud cloud = cloud_of(result);
  EXPECT_TRUE(result.report.viewpoint_applied);
  EXPECT_TRUE(cloud.points.row(0).isApprox(Eigen::RowVector3d(10, 21, 30), 1e-12));
  EXPECT_TRUE(cloud.points.row(1).isApprox(Eigen::RowVector3d(8, 20, 33), 1e-12));
  EXPECT_TRUE(cloud.normals.row(0).isApprox(Eigen::RowVector3d(0, 1, 0), 1e-12));
  EXPECT_TRUE(cloud.normals.row(1).isApprox(Eigen::RowVector3d(-1, 0, 0), 1e-12));
}

TEST(Pcd, OlderVersionsAndMinimalHeaders) {
  // 0.5 named the fields COLUMNS and had no COUNT, HEIGHT, VIEWPOINT or WIDTH; POINTS alone counts.
  const ReadResult result = read_pcd("old.pcd", "COLUMNS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n");
  EXPECT_EQ(cloud_of(result).points.rows(), 2);
  EXPECT_EQ(read_pcd("v6.pcd", "VERSION .6\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n")
                .report.vertices_read,
            1U);
  EXPECT_EQ(read_pcd("empty.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 0\nDATA binary\n").report.vertices_read, 0U);
}

TEST(Pcd, LzfBackReferencesAndRuns) {
  // "abc", then 6 bytes from 3 back (overlapping its own output), then a run of 7 + 2 + 255 "c"s.
  const std::string block = std::string("\x02" "abc", 4) + std::string("\x80\x02", 2) + std::string("\xe0\xff\x00", 3);
  EXPECT_EQ(lzf_decompress(block, 9 + 264), "abcabcabc" + std::string(264, 'c'));
  try {
    lzf_decompress(block, 10);
    FAIL() << "no error";
  } catch (const LzfError& e) {
    EXPECT_EQ(e.offset, 6U);
    EXPECT_THAT(e.what(), HasSubstr("decodes to more than the 10 bytes announced"));
  }
  EXPECT_THROW(lzf_decompress(block, 300), LzfError);                      // fewer than announced
  EXPECT_THROW(lzf_decompress("\x20", 3), LzfError);                       // cut off reference
  EXPECT_THROW(lzf_decompress(std::string("\x05" "ab", 3), 6), LzfError);  // cut off literal run
  EXPECT_THROW(lzf_decompress("ab", 1000), LzfError);                      // beyond any expansion
}

struct Malformed {
  std::string file;
  std::string error;  // "line N: ..." or "byte N: ..."
};

const std::string xyz_header = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n";

TEST(Pcd, EveryMalformedHeaderNamesItsLine) {
  const std::string tail = "WIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n";
  const std::vector<Malformed> cases = {
      {"VERSION 0.8\n" + xyz_header + "DATA ascii\n1 2 3\n", "line 1: unsupported PCD version '0.8'; expected 0.5, 0.6 or 0.7"},
      {"ply\nformat ascii 1.0\n", "line 1: unexpected 'ply' in the header; expected VERSION, FIELDS"},
      {xyz_header, "line 6: file ends here; the header has no DATA line"},
      {xyz_header + "DATA text\n", "line 7: unknown DATA 'text'; expected ascii, binary or binary_compressed"},
      {xyz_header + "FIELDS x y z\nDATA ascii\n", "line 7: a second FIELDS line (the first is line 1)"},
      {"FIELDS\n", "line 1: FIELDS without a value"},
      {"SIZE 4 4 4\nTYPE F F F\n" + tail, "line 5: the header has no FIELDS line"},
      {"FIELDS x y z\nTYPE F F F\n" + tail, "line 5: the header has no SIZE line"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F\n" + tail, "line 3: TYPE has 2 entries but FIELDS (line 1) has 3"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1 1\n" + tail, "line 4: COUNT has 4 entries but FIELDS (line 1) has 3"},
      {"FIELDS x y z\nSIZE 4 3 4\nTYPE F F F\n" + tail, "line 2: field 'y' has SIZE '3'; expected 1, 2, 4 or 8"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F D F\n" + tail, "line 3: field 'y' has TYPE 'D'; expected F, I or U"},
      {"FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\n" + tail, "line 2: field 'z' is a float of 2 bytes; a PCD float has 4 or 8"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 0 1\n" + tail, "line 4: field 'y' has COUNT '0'; expected an integer from 1 to"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 x\n" + tail, "line 4: field 'z' has COUNT 'x'; expected an integer"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 2\n" + tail, "line 4: field 'z' has COUNT 2; a coordinate or normal component has 1"},
      {"FIELDS x y z d\nSIZE 4 4 4 8\nTYPE F F F F\nCOUNT 1 1 1 99999\n" + tail, "line 4: field 'd' has COUNT '99999'; expected an integer from 1 to 93 (the file's size)"},
      {"FIELDS x y z x\nSIZE 4 4 4 4\nTYPE F F F F\n" + tail, "line 1: field 'x' appears twice"},
      {"FIELDS x y rgb\nSIZE 4 4 4\nTYPE F F F\n" + tail, "line 1: FIELDS lacks one of x, y, z"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH -1\nDATA ascii\n", "line 4: WIDTH '-1' is not a count from 0 to"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1 2\nDATA ascii\n", "line 4: WIDTH takes one value"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nHEIGHT 1\nDATA ascii\n", "line 5: the header has no WIDTH and no POINTS line"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA ascii\n", "line 6: POINTS 3 is not WIDTH × HEIGHT (2 × 2)"},
      {xyz_header + "POINTS 99999999999999999999999\nDATA ascii\n", "line 7: POINTS '99999999999999999999999' is not a count"},
      {xyz_header + "VIEWPOINT 0 0 0 1 0 0\nDATA ascii\n", "line 7: VIEWPOINT takes 7 values: tx ty tz qw qx qy qz"},
      {xyz_header + "VIEWPOINT 0 0 nan 1 0 0 0\nDATA ascii\n", "line 7: VIEWPOINT value 'nan' is not a finite number"},
      {xyz_header + "VIEWPOINT 0 0 0 0 0 0 0\nDATA ascii\n", "line 7: VIEWPOINT's quaternion qw qx qy qz is zero"},
  };
  for (const Malformed& c : cases) EXPECT_THAT(error_of(c.file), HasSubstr("bad.pcd: " + c.error)) << c.file;
}

TEST(Pcd, EveryMalformedBodyNamesItsLineOrByte) {
  const std::string two = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\n";  // data from line 6 on
  const std::string normals = "FIELDS x y z normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\nWIDTH 1\nDATA ascii\n";
  const std::string binary = two + "DATA binary\n";
  const std::string compressed = two + "DATA binary_compressed\n";
  const std::string points(24, '\0');
  const std::vector<Malformed> cases = {
      {two + "DATA ascii\n1 2\n4 5 6\n", "line 6: point 0 has 2 values; the fields take 3"},
      {two + "DATA ascii\n1 2 3\n", "line 4: the header announces 2 points but the data ends after 1"},
      {two + "DATA ascii\n1 2 3\n4 5 6\n7 8 9\n", "line 8: data after the last point the header announces"},
      {two + "DATA ascii\n1 2 3\n4 abc 6\n", "line 7: 'abc' is not a number"},
      {two + "DATA ascii\n1 2 3\n4 inf 6\n", "line 7: point 1 has y inf"},
      {normals + "1 2 3 nan 0 1\n", "line 6: point 0 has normal_x nan"},
      {binary + points.substr(0, 20), "byte " + std::to_string(binary.size() + 12) +
                                          ": truncated: the header announces 2 points of 12 bytes but the data holds 1 (20 bytes)"},
      {binary + points + "\0\0x\0"s, "byte " + std::to_string(binary.size() + 26) +
                                          ": 4 bytes after the last point the header announces, and not the zeros PCL pads"},
      {compressed + "\1\0\0\0"s, "byte " + std::to_string(compressed.size()) +
                                     ": truncated: binary_compressed data starts with two 4-byte sizes"},
      {compressed + u32(100) + u32(24) + lzf_literals(points),
       "byte " + std::to_string(compressed.size()) + ": truncated: the compressed block of 100 bytes runs past the end"},
      {compressed + u32(26) + u32(28) + lzf_literals(points) + "\0\0"s,
       "byte " + std::to_string(compressed.size() + 4) + ": the compressed block holds 28 bytes, but 2 points of 12 bytes take 24"},
      {compressed + u32(25) + u32(24) + lzf_literals(points) + "\x01"s,
       "byte " + std::to_string(compressed.size() + 8 + 25) + ": 1 bytes after the compressed block, and not the zeros"},
      {compressed + u32(2) + u32(24) + "\x20\x00"s,
       "byte " + std::to_string(compressed.size() + 8) + ": bad LZF data: a back reference reaches 1 bytes back, before the start"},
      {compressed + u32(4) + u32(24) + "\x00\x01\x20\x05"s,
       "byte " + std::to_string(compressed.size() + 10) + ": bad LZF data: a back reference reaches 6 bytes back, before the start"},
  };
  for (const Malformed& c : cases) EXPECT_THAT(error_of(c.file), HasSubstr("bad.pcd: " + c.error)) << c.file;
}

TEST(Pcd, HostileCountsAreRefusedBeforeAnyAllocation) {
  // A 60-byte binary file claiming a billion points, and a compressed block claiming 4 GB.
  const std::string header = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 40\nHEIGHT 1\nPOINTS 40\nDATA ";
  EXPECT_THAT(error_of(header + "binary\n" + std::string(12, '\0')), HasSubstr("truncated: the header announces 40 points"));
  EXPECT_THAT(error_of(header + "binary_compressed\n" + u32(1) + u32(0xffffffffU) + "\0"s),
              HasSubstr("the compressed block holds 4294967295 bytes, but 40 points of 12 bytes take 480"));
  EXPECT_THAT(error_of("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 999999999\nHEIGHT 1\nDATA ascii\n"),
              HasSubstr("line 4: WIDTH '999999999' is not a count from 0 to"));
}

TEST(Pcd, BrokenFilesGiveOneFileErrorNamingFileAndLocation) {
  const std::vector<Malformed> cases = {
      {"nan.pcd", "line 13: point 1 has y nan (NaN marks a missing return only in an organized cloud, HEIGHT > 1)"},
      {"size_entries.pcd", "line 4: SIZE has 2 entries but FIELDS (line 3) has 3"},
      {"no_z.pcd", "line 3: FIELDS lacks one of x, y, z"},
      {"truncated.pcd", "byte 188: truncated: the header announces 3 points of 12 bytes but the data holds 2 (32 bytes)"},
      {"points_not_width_height.pcd", "line 10: POINTS 3 is not WIDTH × HEIGHT (2 × 2)"},
      {"bad_lzf.pcd", "byte 183: bad LZF data: a back reference reaches 1 bytes back, before the start"},
  };
  for (const Malformed& c : cases) {
    const fs::path file = fs::path(CMMD_TEST_DATA_DIR) / "broken" / c.file;
    try {
      read_model(file);
      ADD_FAILURE() << c.file << ": no error";
    } catch (const FileError& e) {
      EXPECT_THAT(e.what(), HasSubstr(file.string() + ": " + c.error));
    }
  }
}

TEST(Pcd, EveryTruncationAndCorruptionGivesACloudOrAFileError) {
  // Each encoding, cut at every length and with every byte overwritten: never out of bounds (ASan),
  // never another exception, and what is accepted keeps the readers' promises.
  Cloud c;
  c.fields = {{"x", 4, 'F'}, {"y", 8, 'F'}, {"z", 2, 'I'}, {"normal_x", 4, 'F'}, {"normal_y", 4, 'F'},
              {"normal_z", 4, 'F'}, {"rgb", 4, 'U'}};
  c.points = {{1, 2, 3, 0, 0, 1, 5}, {4, 5, 6, 1, 0, 0, 6}};
  std::size_t errors = 0, clouds = 0;
  for (const std::string& data : encodings) {
    const std::string bytes = c.render(data);
    std::vector<std::string> variants;
    for (std::size_t cut = 0; cut < bytes.size(); ++cut) variants.push_back(bytes.substr(0, cut));
    for (std::size_t at = 0; at < bytes.size(); ++at) {
      for (const char b : {'\0', '\n', ' ', '9', '-', '\xff'}) {
        variants.push_back(bytes);
        variants.back()[at] = b;
      }
    }
    for (const std::string& variant : variants) {
      try {
        const PointCloud cloud = cloud_of(read_pcd("fuzzed", variant));
        EXPECT_TRUE(cloud.points.allFinite());
        EXPECT_TRUE(cloud.normals.rows() == 0 || cloud.normals.rows() == cloud.points.rows());
        ++clouds;
      } catch (const FileError&) {
        ++errors;
      }
    }
  }
  EXPECT_GT(errors, 0U);
  EXPECT_GT(clouds, 0U);
}

TEST(Pcd, MeshIoKnowsPcdAndAsc) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("cmmd_pcd_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  PointCloud cloud;
  cloud.points.resize(2, 3);
  cloud.points << 0.5, 1.25, -3, 100, 200, 300;  // float-exact: write_cloud writes PCD as float32
  cloud.normals.resize(2, 3);
  cloud.normals << 0, 0, 1, 0, -1, 0;
  for (const char* name : {"cloud.pcd", "cloud.asc", "CLOUD.PCD"}) {
    write_cloud(dir / name, cloud);
    const PointCloud read = cloud_of(read_model(dir / name));
    EXPECT_EQ(read.points, cloud.points) << name;
    EXPECT_EQ(read.normals, cloud.normals) << name;
  }
  std::ofstream(dir / "commas.asc") << "1,2,3\n4,5,6\n";
  EXPECT_EQ(cloud_of(read_model(dir / "commas.asc")).points.rows(), 2);
  EXPECT_THROW(read_mesh(dir / "cloud.pcd"), FileError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cmm::geometry
