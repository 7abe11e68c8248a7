// One statement per line; OBJ indices are 1-based, and negative ones count back from the last vertex
// (or normal) defined so far, so every index is resolved against what precedes its line.
#include "geometry/obj_io.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include "geometry/text_io.hpp"

namespace cmm::geometry {

namespace {

int resolve(const TextScanner& text, std::string_view token, std::size_t defined, const std::string& what,
            const std::string& plural) {
  const long long index = text.integer(token);
  const long long resolved = index < 0 ? static_cast<long long>(defined) + index : index - 1;
  if (resolved < 0 || resolved >= static_cast<long long>(defined)) {  // index 0 lands here too
    throw text.error("face has " + what + " index " + std::to_string(index) + ", but the file has " +
                     std::to_string(defined) + " " + plural + " up to this line");
  }
  return static_cast<int>(resolved);
}

void append_row(std::string& out, std::string_view keyword, const auto& row) {
  out += keyword;
  for (Eigen::Index k = 0; k < 3; ++k) {
    out += ' ';
    append_number(out, row[k]);
  }
  out += '\n';
}

bool has_normals(const Points& points, const Points& normals) {
  return normals.rows() > 0 && normals.rows() == points.rows();
}

std::string vertex_lines(const Points& points, const Points& normals) {
  std::string text;
  for (Eigen::Index v = 0; v < points.rows(); ++v) append_row(text, "v", points.row(v));
  for (Eigen::Index v = 0; has_normals(points, normals) && v < points.rows(); ++v) {
    append_row(text, "vn", normals.row(v));
  }
  return text;
}

Points rows_of(const std::vector<double>& values) {
  return Eigen::Map<const Points>(values.data(), static_cast<Eigen::Index>(values.size() / 3), 3);
}

}  // namespace

ReadResult read_obj(const std::filesystem::path& file, std::string_view bytes) {
  TextScanner text(file, bytes, '#');
  std::vector<double> points, normals;
  std::vector<int> triangles;
  std::vector<int> normal_of;  // per vertex: the first normal a face corner gave it, -1 for none
  std::vector<int> face;
  ReadReport report;
  while (text.next_line()) {
    const auto& tokens = text.tokens();
    const std::string_view keyword = tokens[0];
    if (keyword == "v" || keyword == "vn") {
      // "v x y z" may go on with a w or a colour, which are not needed.
      if (tokens.size() < 4) throw text.error("expected '" + std::string(keyword) + " x y z'");
      auto& target = keyword == "v" ? points : normals;
      for (std::size_t k = 1; k <= 3; ++k) target.push_back(text.finite(tokens[k]));
    } else if (keyword == "f") {
      if (tokens.size() < 4) throw text.error("a face needs at least 3 corners");
      const std::size_t vertex_count = points.size() / 3;
      normal_of.resize(vertex_count, -1);
      face.clear();
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        // Corners are v, v/t, v//n or v/t/n.
        const std::string_view corner = tokens[k];
        const std::size_t slash = corner.find('/');
        const int v = resolve(text, corner.substr(0, slash), vertex_count, "vertex", "vertices");
        face.push_back(v);
        const std::size_t second = slash == std::string_view::npos ? slash : corner.find('/', slash + 1);
        if (second != std::string_view::npos && second + 1 < corner.size()) {
          const int n = resolve(text, corner.substr(second + 1), normals.size() / 3, "normal", "normals");
          if (normal_of[static_cast<std::size_t>(v)] < 0) normal_of[static_cast<std::size_t>(v)] = n;
        }
      }
      if (face.size() > 3) ++report.polygons_triangulated;
      for (std::size_t k = 1; k + 1 < face.size(); ++k) {
        triangles.insert(triangles.end(), {face[0], face[k], face[k + 1]});
      }
    }
  }

  const std::size_t vertex_count = points.size() / 3;
  report.vertices_read = vertex_count;
  report.faces_read = triangles.size() / 3;
  if (triangles.empty()) {
    if (!normals.empty() && normals.size() != points.size()) {
      throw FileError::whole(file, "a cloud's vn lines pair with its v lines, but there are " +
                                       std::to_string(normals.size() / 3) + " vn for " + std::to_string(vertex_count) +
                                       " v");
    }
    return {PointCloud{rows_of(points), rows_of(normals)}, report};
  }

  TriangleMesh mesh{rows_of(points),
                    Eigen::Map<const Triangles>(triangles.data(), static_cast<Eigen::Index>(report.faces_read), 3),
                    Points(0, 3)};
  normal_of.resize(vertex_count, -1);
  if (std::ranges::none_of(normal_of, [](int n) { return n < 0; })) {
    mesh.vertex_normals.resize(static_cast<Eigen::Index>(vertex_count), 3);
    const Points all_normals = rows_of(normals);
    for (std::size_t v = 0; v < vertex_count; ++v) {
      mesh.vertex_normals.row(static_cast<Eigen::Index>(v)) = all_normals.row(normal_of[v]);
    }
  }
  return {std::move(mesh), report};
}

void write_obj(std::ostream& out, const TriangleMesh& mesh) {
  std::string text = vertex_lines(mesh.vertices, mesh.vertex_normals);
  const bool with_normals = has_normals(mesh.vertices, mesh.vertex_normals);
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    text += 'f';
    for (Eigen::Index k = 0; k < 3; ++k) {
      const int corner = mesh.faces(f, k) + 1;
      text += ' ';
      append_number(text, corner);
      if (!with_normals) continue;
      text += "//";
      append_number(text, corner);
    }
    text += '\n';
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

void write_obj(std::ostream& out, const PointCloud& cloud) {
  const std::string text = vertex_lines(cloud.points, cloud.normals);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

}  // namespace cmm::geometry
