// Binary STL: an 80-byte header, a uint32 facet count, then 50 bytes per facet (normal, three corners
// as float32, a uint16 attribute). ASCII STL: solid / facet normal / outer loop / 3 × vertex / endloop /
// endfacet / endsolid, one keyword per line.
#include "geometry/stl_io.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "geometry/file_error.hpp"
#include "geometry/mesh_cleanup.hpp"
#include "geometry/text_io.hpp"

namespace cmm::geometry {

namespace {

constexpr std::size_t header_bytes = 84;  // 80 free bytes, then the facet count
constexpr std::size_t facet_bytes = 50;

// Byte by byte, so the host's endianness does not matter; compilers turn this into one load.
std::uint32_t load_u32(const char* p) {
  const auto* b = reinterpret_cast<const unsigned char*>(p);
  return std::uint32_t{b[0]} | std::uint32_t{b[1]} << 8 | std::uint32_t{b[2]} << 16 | std::uint32_t{b[3]} << 24;
}

void store_u32(char* p, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<char>(value >> (8 * i));
}

// The size test comes first: a binary header may start with "solid" (several CAD exporters do this).
// Failing it, an ASCII file starts with "solid" and has no NUL where a binary file has its facet count
// (below 2^24 facets, the count's top byte is 0).
bool is_binary(std::string_view bytes) {
  if (bytes.size() >= header_bytes &&
      bytes.size() == header_bytes + facet_bytes * load_u32(bytes.data() + header_bytes - 4)) {
    return true;
  }
  const std::string_view start = bytes.substr(0, header_bytes);
  const std::size_t text = start.find_first_not_of(" \t\r\n");
  return text == std::string_view::npos || !start.substr(text).starts_with("solid") ||
         start.find('\0') != std::string_view::npos;
}

ReadResult read_binary(const std::filesystem::path& file, std::string_view bytes) {
  const auto size = std::to_string(bytes.size());
  if (bytes.size() < header_bytes) {
    throw FileError::at_byte(
        file, 0, "truncated: a binary STL starts with an 84-byte header but the file has " + size + " bytes");
  }
  const std::size_t facets = load_u32(bytes.data() + header_bytes - 4);
  const std::size_t expected = header_bytes + facet_bytes * facets;
  const std::string announced =
      "header announces " + std::to_string(facets) + " facets (" + std::to_string(expected) + " bytes)";
  if (bytes.size() < expected) {
    const std::size_t first_incomplete = header_bytes + facet_bytes * ((bytes.size() - header_bytes) / facet_bytes);
    throw FileError::at_byte(file, first_incomplete,
                             "truncated: " + announced + " but the file has " + size + " bytes");
  }
  if (bytes.size() > expected) {
    throw FileError::at_byte(file, header_bytes - 4, announced + " but the file has " + size + " bytes");
  }

  // Corner i is corner i % 3 of facet i / 3, after the facet's normal.
  const auto record = [](std::size_t i) { return header_bytes + facet_bytes * (i / 3); };
  const auto corner = [&](std::size_t i) -> Vec3 {
    const char* p = bytes.data() + record(i) + 12 * (1 + i % 3);
    return {std::bit_cast<float>(load_u32(p)), std::bit_cast<float>(load_u32(p + 4)),
            std::bit_cast<float>(load_u32(p + 8))};
  };
  // A first pass for the bounding box, which sets the weld tolerance, and for non-finite values.
  Vec3 low = Vec3::Constant(std::numeric_limits<double>::infinity()), high = -low;
  for (std::size_t i = 0; i < 3 * facets; ++i) {
    const Vec3 p = corner(i);
    for (const double c : p) {
      if (!std::isfinite(c)) {
        throw FileError::at_byte(
            file, record(i),
            "facet " + std::to_string(i / 3) + " has a non-finite coordinate (" + std::to_string(c) + ")");
      }
    }
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  TriangleMesh mesh;
  mesh.faces.resize(static_cast<Eigen::Index>(facets), 3);
  mesh.vertices = weld_points(3 * facets, corner, low, high, mesh.faces.data());
  ReadReport report;
  report.vertices_read = 3 * facets;
  report.faces_read = facets;
  report.vertices_welded = report.vertices_read - static_cast<std::size_t>(mesh.vertices.rows());
  return {std::move(mesh), report};
}

// Moves to the next line and checks that it starts with `first` (and `second`, when given).
void expect_line(TextScanner& text, std::string_view first, std::string_view second = {}) {
  std::string keywords(first);
  if (!second.empty()) keywords.append(" ").append(second);
  const std::string wanted = in_quotes(keywords);
  if (!text.next_line()) throw text.error("file ends here; expected " + wanted);
  const auto& tokens = text.tokens();
  if (tokens[0] != first || (!second.empty() && (tokens.size() < 2 || tokens[1] != second))) {
    throw text.error("expected " + wanted + ", got " + in_quotes(tokens[0]));
  }
}

ReadResult read_ascii(const std::filesystem::path& file, std::string_view bytes) {
  TextScanner text(file, bytes);
  expect_line(text, "solid");
  std::vector<double> corners;
  for (;;) {
    if (!text.next_line()) throw text.error("file ends here; expected 'endsolid'");
    const std::string_view keyword = text.tokens()[0];
    if (keyword == "endsolid") {
      if (!text.next_line()) break;
      // Some exporters write one solid per part into the same file.
      if (text.tokens()[0] != "solid") {
        throw text.error("expected 'solid' or the end of the file, got " + in_quotes(text.tokens()[0]));
      }
      continue;
    }
    if (keyword != "facet") throw text.error("expected 'facet' or 'endsolid', got " + in_quotes(keyword));
    expect_line(text, "outer", "loop");
    for (int k = 0; k < 3; ++k) {
      expect_line(text, "vertex");
      if (text.tokens().size() != 4) throw text.error("expected 'vertex x y z'");
      for (int axis = 1; axis <= 3; ++axis) {
        corners.push_back(text.finite(text.tokens()[static_cast<std::size_t>(axis)]));
      }
    }
    expect_line(text, "endloop");
    expect_line(text, "endfacet");
  }
  TriangleMesh mesh;
  mesh.vertices = Eigen::Map<const Points>(corners.data(), static_cast<Eigen::Index>(corners.size() / 3), 3);
  // Facet f's corners are vertices 3f, 3f+1, 3f+2 until welding merges them.
  mesh.faces.resize(mesh.vertices.rows() / 3, 3);
  std::iota(mesh.faces.data(), mesh.faces.data() + mesh.faces.size(), 0);
  ReadReport report;
  report.vertices_read = static_cast<std::size_t>(mesh.vertices.rows());
  report.faces_read = static_cast<std::size_t>(mesh.faces.rows());
  weld_vertices(mesh, report);
  return {std::move(mesh), report};
}

}  // namespace

ReadResult read_stl(const std::filesystem::path& file, std::string_view bytes) {
  return is_binary(bytes) ? read_binary(file, bytes) : read_ascii(file, bytes);
}

void write_stl(std::ostream& out, const TriangleMesh& mesh) {
  const auto facets = static_cast<std::size_t>(mesh.faces.rows());
  std::string bytes(header_bytes + facet_bytes * facets, '\0');
  // Must not start with "solid", or naive readers take the file for ASCII.
  const std::string_view title = "binary STL written by cmmd";
  bytes.replace(0, title.size(), title);
  store_u32(bytes.data() + header_bytes - 4, static_cast<std::uint32_t>(facets));
  for (std::size_t f = 0; f < facets; ++f) {
    const auto face = mesh.faces.row(static_cast<Eigen::Index>(f));
    const Vec3 a = vertex(mesh, face[0]), b = vertex(mesh, face[1]), c = vertex(mesh, face[2]);
    const Vec3 normal = (b - a).cross(c - a).normalized();  // stays zero for a degenerate face
    char* p = bytes.data() + header_bytes + facet_bytes * f;
    for (const Vec3& v : {normal, a, b, c}) {
      for (int axis = 0; axis < 3; ++axis, p += 4) {
        store_u32(p, std::bit_cast<std::uint32_t>(static_cast<float>(v[axis])));
      }
    }
  }
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace cmm::geometry
