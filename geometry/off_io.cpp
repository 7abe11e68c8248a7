// Read line by line rather than as a token stream, as every writer puts one vertex or face per line:
// a line with the wrong number of values then shows where the counts and the data part ways.
#include "geometry/off_io.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include "geometry/text_io.hpp"

namespace cmm::geometry {

namespace {

// A colour is optional and given as a colour-map index or as RGB or RGBA.
bool is_colour(std::size_t values) { return values == 0 || values == 1 || values == 3 || values == 4; }

Points rows_of(const std::vector<double>& values) {
  return Eigen::Map<const Points>(values.data(), static_cast<Eigen::Index>(values.size() / 3), 3);
}

void write(std::ostream& out, const Points& points, const Points& normals, const Triangles& faces) {
  const bool with_normals = normals.rows() > 0 && normals.rows() == points.rows();
  std::string text = with_normals ? "NOFF\n" : "OFF\n";
  text += std::to_string(points.rows()) + " " + std::to_string(faces.rows()) + " 0\n";
  for (Eigen::Index v = 0; v < points.rows(); ++v) {
    for (Eigen::Index k = 0; k < (with_normals ? 6 : 3); ++k) {
      if (k > 0) text += ' ';
      append_number(text, k < 3 ? points(v, k) : normals(v, k - 3));
    }
    text += '\n';
  }
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    text += '3';
    for (Eigen::Index k = 0; k < 3; ++k) {
      text += ' ';
      append_number(text, faces(f, k));
    }
    text += '\n';
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

}  // namespace

ReadResult read_off(const std::filesystem::path& file, std::string_view bytes) {
  TextScanner text(file, bytes, '#');
  const std::string_view variants[] = {"OFF", "NOFF", "COFF", "CNOFF"};
  if (!text.next_line() || std::ranges::find(variants, text.tokens()[0]) == std::end(variants)) {
    throw FileError::at_line(file, std::max<std::size_t>(text.line_number(), 1),
                             "missing header: expected OFF, NOFF, COFF or CNOFF");
  }
  const bool with_normals = text.tokens()[0].find('N') != std::string_view::npos;
  const bool with_colours = text.tokens()[0].starts_with('C');

  // The counts may follow the header word on its line.
  std::vector<std::string_view> counts(text.tokens().begin() + 1, text.tokens().end());
  if (counts.empty() && text.next_line()) counts = text.tokens();
  if (counts.size() != 2 && counts.size() != 3) throw text.error("expected 'vertex_count face_count [edge_count]'");
  const long long vertex_count = text.integer(counts[0]);
  const long long face_count = text.integer(counts[1]);
  if (vertex_count < 0 || face_count < 0) throw text.error("negative count");
  const std::size_t counts_line = text.line_number();
  const auto ends_early = [&](const std::string& read) {
    return FileError::at_line(file, counts_line,
                              "header announces " + std::to_string(vertex_count) + " vertices and " +
                                  std::to_string(face_count) + " faces but the file ends after " + read);
  };

  const std::size_t fields = with_normals ? 6 : 3;
  std::vector<double> points, normals;
  points.reserve(3 * std::min(static_cast<std::size_t>(vertex_count), bytes.size()));
  for (long long v = 0; v < vertex_count; ++v) {
    if (!text.next_line()) throw ends_early(std::to_string(v) + " vertices");
    const auto& tokens = text.tokens();
    if (tokens.size() < fields || !is_colour(tokens.size() - fields) || (!with_colours && tokens.size() != fields)) {
      throw text.error("vertex " + std::to_string(v) + " has " + std::to_string(tokens.size()) + " values; expected " +
                       (with_normals ? "x y z nx ny nz" : "x y z") + (with_colours ? " and a colour" : ""));
    }
    for (std::size_t k = 0; k < fields; ++k) (k < 3 ? points : normals).push_back(text.finite(tokens[k]));
  }

  ReadReport report;
  std::vector<int> triangles, face;
  for (long long f = 0; f < face_count; ++f) {
    if (!text.next_line()) throw ends_early(std::to_string(f) + " faces");
    const auto& tokens = text.tokens();
    const long long corners = text.integer(tokens[0]);
    if (corners < 3) {
      throw text.error("face " + std::to_string(f) + " has " + std::to_string(corners) +
                       " corners; a face needs at least 3");
    }
    if (tokens.size() < static_cast<std::size_t>(corners) + 1 ||
        !is_colour(tokens.size() - 1 - static_cast<std::size_t>(corners))) {
      throw text.error("face " + std::to_string(f) + " announces " + std::to_string(corners) + " corners but has " +
                       std::to_string(tokens.size() - 1) + " values after the count");
    }
    face.clear();
    for (long long k = 1; k <= corners; ++k) {
      const long long index = text.integer(tokens[static_cast<std::size_t>(k)]);
      if (index < 0 || index >= vertex_count) {
        throw text.error("face " + std::to_string(f) + " has vertex index " + std::to_string(index) +
                         ", but the file has " + std::to_string(vertex_count) + " vertices");
      }
      face.push_back(static_cast<int>(index));
    }
    if (corners > 3) ++report.polygons_triangulated;
    for (std::size_t k = 1; k + 1 < face.size(); ++k) {
      triangles.insert(triangles.end(), {face[0], face[k], face[k + 1]});
    }
  }
  if (text.next_line()) {
    throw text.error("data after the " + std::to_string(face_count) + " faces the header announces");
  }

  report.vertices_read = static_cast<std::size_t>(vertex_count);
  report.faces_read = triangles.size() / 3;
  if (triangles.empty()) return {PointCloud{rows_of(points), rows_of(normals)}, report};
  TriangleMesh mesh{rows_of(points),
                    Eigen::Map<const Triangles>(triangles.data(), static_cast<Eigen::Index>(report.faces_read), 3),
                    rows_of(normals)};
  return {std::move(mesh), report};
}

void write_off(std::ostream& out, const TriangleMesh& mesh) {
  write(out, mesh.vertices, mesh.vertex_normals, mesh.faces);
}

void write_off(std::ostream& out, const PointCloud& cloud) { write(out, cloud.points, cloud.normals, Triangles(0, 3)); }

}  // namespace cmm::geometry
