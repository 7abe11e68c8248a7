// Every point line is checked against the first one's column count, so a stray line cannot shift the
// normals into the coordinates unnoticed.
#include "geometry/xyz_io.hpp"

#include <string>
#include <vector>

#include "geometry/text_io.hpp"

namespace cmm::geometry {

namespace {

Points rows_of(const std::vector<double>& values) {
  return Eigen::Map<const Points>(values.data(), static_cast<Eigen::Index>(values.size() / 3), 3);
}

}  // namespace

ReadResult read_xyz(const std::filesystem::path& file, std::string_view bytes) {
  TextScanner text(file, bytes, '#', true);
  std::vector<double> points, normals;
  std::size_t columns = 0;
  std::size_t first_line = 0;
  while (text.next_line()) {
    const auto& tokens = text.tokens();
    if (tokens.size() != 3 && tokens.size() != 6) {
      throw text.error(std::to_string(tokens.size()) + " values; expected 'x y z' or 'x y z nx ny nz'");
    }
    if (columns == 0) {
      columns = tokens.size();
      first_line = text.line_number();
    } else if (tokens.size() != columns) {
      throw text.error(std::to_string(tokens.size()) + " values, but the first point (line " +
                       std::to_string(first_line) + ") has " + std::to_string(columns));
    }
    for (std::size_t k = 0; k < columns; ++k) (k < 3 ? points : normals).push_back(text.finite(tokens[k]));
  }
  ReadReport report;
  report.vertices_read = points.size() / 3;
  return {PointCloud{rows_of(points), rows_of(normals)}, report};
}

void write_xyz(std::ostream& out, const PointCloud& cloud) {
  const bool with_normals = cloud.normals.rows() > 0 && cloud.normals.rows() == cloud.points.rows();
  std::string text;
  for (Eigen::Index v = 0; v < cloud.points.rows(); ++v) {
    for (Eigen::Index k = 0; k < (with_normals ? 6 : 3); ++k) {
      if (k > 0) text += ' ';
      append_number(text, k < 3 ? cloud.points(v, k) : cloud.normals(v, k - 3));
    }
    text += '\n';
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

}  // namespace cmm::geometry
