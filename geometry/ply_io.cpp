// The header is text in every encoding; the body is read by one loop over the header's elements,
// fed either by text lines (one element instance per line) or by bytes in the file's byte order.
#include "geometry/ply_io.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "geometry/file_error.hpp"
#include "geometry/text_io.hpp"

namespace cmm::geometry {

namespace {

enum class Scalar { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

// Each type's classic and sized names, in the order of Scalar; files use both.
constexpr std::string_view scalar_names[][2] = {{"char", "int8"},     {"uchar", "uint8"},   {"short", "int16"},
                                                {"ushort", "uint16"}, {"int", "int32"},     {"uint", "uint32"},
                                                {"float", "float32"}, {"double", "float64"}};

bool is_integer(Scalar type) { return type < Scalar::float32; }

struct Property {
  std::string name;
  Scalar type;                       // of the value, or of each list item
  std::optional<Scalar> list_count;  // set for a list property
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::size_t line = 0;  // of its "element" line, where a wrong count is reported
  std::vector<Property> properties;
};

enum class Encoding { ascii, little_endian, big_endian };

struct Header {
  Encoding encoding = Encoding::ascii;
  std::vector<Element> elements;
};

Scalar scalar_type(const TextScanner& text, std::string_view name) {
  for (std::size_t type = 0; type < std::size(scalar_names); ++type) {
    if (scalar_names[type][0] == name || scalar_names[type][1] == name) return static_cast<Scalar>(type);
  }
  throw text.error("unknown property type " + in_quotes(name) +
                   "; expected char, uchar, short, ushort, int, uint, float or double (or int8 ... float64)");
}

Header read_header(const std::filesystem::path& file, std::string_view bytes, TextScanner& text) {
  if (!bytes.starts_with("ply\n") && !bytes.starts_with("ply\r\n")) {
    throw FileError::at_line(file, 1, "bad magic: a PLY file starts with a line 'ply'");
  }
  text.next_line();
  Header header;
  bool has_format = false;
  for (;;) {
    if (!text.next_line()) throw text.error("file ends here; the header has no 'end_header'");
    const auto& tokens = text.tokens();
    const std::string_view keyword = tokens[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") break;
    if (keyword == "format") {
      if (tokens.size() != 3) throw text.error("expected 'format <encoding> 1.0'");
      if (tokens[1] == "ascii") {
        header.encoding = Encoding::ascii;
      } else if (tokens[1] == "binary_little_endian") {
        header.encoding = Encoding::little_endian;
      } else if (tokens[1] == "binary_big_endian") {
        header.encoding = Encoding::big_endian;
      } else {
        throw text.error("unknown format " + in_quotes(tokens[1]) +
                         "; expected ascii, binary_little_endian or binary_big_endian");
      }
      if (tokens[2] != "1.0") throw text.error("unsupported PLY version " + in_quotes(tokens[2]) + "; expected 1.0");
      has_format = true;
    } else if (keyword == "element") {
      if (tokens.size() != 3) throw text.error("expected 'element <name> <count>'");
      const long long count = text.integer(tokens[2]);
      if (count < 0) throw text.error("negative element count " + std::to_string(count));
      header.elements.push_back({std::string(tokens[1]), static_cast<std::size_t>(count), text.line_number(), {}});
    } else if (keyword == "property") {
      if (header.elements.empty()) throw text.error("property before any element");
      Property property;
      if (tokens.size() == 5 && tokens[1] == "list") {
        property = {std::string(tokens[4]), scalar_type(text, tokens[3]), scalar_type(text, tokens[2])};
        if (!is_integer(*property.list_count)) {
          throw text.error("list length type " + in_quotes(tokens[2]) + " is not an integer type");
        }
      } else if (tokens.size() == 3) {
        property = {std::string(tokens[2]), scalar_type(text, tokens[1]), std::nullopt};
      } else {
        throw text.error("expected 'property <type> <name>' or 'property list <length type> <item type> <name>'");
      }
      header.elements.back().properties.push_back(std::move(property));
    } else {
      throw text.error("unexpected " + in_quotes(keyword) +
                       " in the header; expected format, element, property, comment or end_header");
    }
  }
  if (!has_format) throw text.error("the header has no 'format' line");
  return header;
}

// Where each property of an element goes: a vertex field (x y z nx ny nz), the face's corners, or nowhere.
constexpr int skipped = -1;
constexpr int corners = 6;

struct Layout {
  std::vector<int> roles;  // per property
  bool has_normals = false;
};

Layout vertex_layout(const std::filesystem::path& file, const Element& element) {
  static constexpr std::array<std::string_view, 6> fields{"x", "y", "z", "nx", "ny", "nz"};
  Layout layout{std::vector<int>(element.properties.size(), skipped)};
  std::array<bool, 6> found{};
  for (std::size_t p = 0; p < element.properties.size(); ++p) {
    const auto field = std::find(fields.begin(), fields.end(), element.properties[p].name);
    if (field == fields.end() || element.properties[p].list_count) continue;
    const auto role = static_cast<std::size_t>(field - fields.begin());
    layout.roles[p] = static_cast<int>(role);
    found[role] = true;
  }
  if (!found[0] || !found[1] || !found[2]) {
    throw FileError::at_line(file, element.line, "the vertex element lacks one of the properties x, y, z");
  }
  layout.has_normals = found[3] && found[4] && found[5];
  return layout;
}

Layout face_layout(const std::filesystem::path& file, const Element& element) {
  Layout layout{std::vector<int>(element.properties.size(), skipped)};
  for (std::size_t p = 0; p < element.properties.size(); ++p) {
    const Property& property = element.properties[p];
    if (property.name != "vertex_indices" && property.name != "vertex_index") continue;
    if (!property.list_count || !is_integer(property.type)) {
      throw FileError::at_line(file, element.line, "the face's " + property.name + " is not a list of integers");
    }
    layout.roles[p] = corners;
    return layout;
  }
  throw FileError::at_line(file, element.line, "the face element has no list property vertex_indices");
}

std::string instance(const Element& element, std::size_t index) { return element.name + " " + std::to_string(index); }

// Element instances from text, one per line.
class AsciiBody {
 public:
  AsciiBody(const std::filesystem::path& file, TextScanner& text) : file_(file), text_(text) {}

  void start(const Element& element, std::size_t index) {
    if (!text_.next_line()) {
      throw FileError::at_line(file_, element.line,
                               "header announces " + std::to_string(element.count) + " " + element.name +
                                   " elements but the file ends after " + std::to_string(index));
    }
    element_ = &element;
    index_ = index;
    next_ = 0;
  }
  double value(Scalar type) {
    const auto& tokens = text_.tokens();
    if (next_ == tokens.size()) throw error("too few values for " + instance(*element_, index_));
    const std::string_view token = tokens[next_++];
    return is_integer(type) ? static_cast<double>(text_.integer(token)) : text_.number(token);
  }
  void finish() const {
    if (next_ != text_.tokens().size()) {
      throw error("more values than " + instance(*element_, index_) + " has properties");
    }
  }
  void end() const {
    if (text_.next_line()) throw error("data after the last element the header announces");
  }
  FileError error(const std::string& message) const { return text_.error(message); }

 private:
  const std::filesystem::path& file_;
  TextScanner& text_;
  const Element* element_ = nullptr;
  std::size_t index_ = 0;
  std::size_t next_ = 0;
};

// Element instances from bytes in the file's byte order; errors name the instance's first byte.
class BinaryBody {
 public:
  BinaryBody(const std::filesystem::path& file, std::string_view bytes, std::size_t offset, Encoding encoding)
      : file_(file),
        bytes_(bytes),
        offset_(offset),
        swap_((encoding == Encoding::big_endian) != (std::endian::native == std::endian::big)) {}

  void start(const Element& element, std::size_t index) {
    element_ = &element;
    index_ = index;
    record_ = offset_;
  }
  double value(Scalar type) {
    static constexpr std::array<std::size_t, 8> sizes{1, 1, 2, 2, 4, 4, 4, 8};
    const std::size_t size = sizes[static_cast<std::size_t>(type)];
    if (bytes_.size() - offset_ < size) {
      throw error("truncated: " + instance(*element_, index_) + " runs past the end of the file (" +
                  std::to_string(bytes_.size()) + " bytes)");
    }
    std::array<unsigned char, 8> raw{};
    std::memcpy(raw.data(), bytes_.data() + offset_, size);
    if (swap_) std::reverse(raw.begin(), raw.begin() + static_cast<std::ptrdiff_t>(size));
    offset_ += size;
    switch (type) {
      case Scalar::int8:
        return decode<std::int8_t>(raw);
      case Scalar::uint8:
        return decode<std::uint8_t>(raw);
      case Scalar::int16:
        return decode<std::int16_t>(raw);
      case Scalar::uint16:
        return decode<std::uint16_t>(raw);
      case Scalar::int32:
        return decode<std::int32_t>(raw);
      case Scalar::uint32:
        return decode<std::uint32_t>(raw);
      case Scalar::float32:
        return decode<float>(raw);
      case Scalar::float64:
        return decode<double>(raw);
    }
    return 0;
  }
  void finish() const {}
  void end() const {
    if (offset_ != bytes_.size()) {
      throw FileError::at_byte(
          file_, offset_,
          std::to_string(bytes_.size() - offset_) + " bytes after the last element the header announces");
    }
  }
  FileError error(const std::string& message) const { return FileError::at_byte(file_, record_, message); }

 private:
  template <class T>
  static double decode(const std::array<unsigned char, 8>& raw) {
    T value;
    std::memcpy(&value, raw.data(), sizeof value);
    return static_cast<double>(value);
  }

  const std::filesystem::path& file_;
  std::string_view bytes_;
  std::size_t offset_;
  bool swap_;
  const Element* element_ = nullptr;
  std::size_t index_ = 0;
  std::size_t record_ = 0;
};

struct Body {
  std::vector<double> points;   // x y z per vertex
  std::vector<double> normals;  // nx ny nz per vertex, when the file has them
  std::vector<int> triangles;   // three corners per triangle
  std::size_t polygons = 0;     // faces with more than three corners
};

template <class Source>
Body read_body(const std::filesystem::path& file, const Header& header, std::size_t file_size, Source& source) {
  std::size_t vertex_count = 0;
  for (const Element& element : header.elements) {
    if (element.name == "vertex") vertex_count = element.count;
  }
  Body body;
  std::vector<double> face;
  for (const Element& element : header.elements) {
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    const Layout layout = is_vertex ? vertex_layout(file, element)
                          : is_face ? face_layout(file, element)
                                    : Layout{std::vector<int>(element.properties.size(), skipped)};
    // An instance without properties takes no byte: 6e14 of them would be read for ever (binary).
    if (element.count > 0 && element.properties.empty())
      throw FileError::at_line(file, element.line, "element " + in_quotes(element.name) + " has " +
                                                       std::to_string(element.count) + " instances but no properties");
    // Every instance takes at least a byte, so a count beyond the file size is a lie not to allocate for.
    const std::size_t plausible = std::min(element.count, file_size);
    if (is_vertex) body.points.reserve(3 * plausible);
    if (is_vertex && layout.has_normals) body.normals.reserve(3 * plausible);
    if (is_face) body.triangles.reserve(3 * plausible);

    for (std::size_t i = 0; i < element.count; ++i) {
      source.start(element, i);
      std::array<double, 6> fields{};
      face.clear();
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        const int role = layout.roles[p];
        if (!property.list_count) {
          const double value = source.value(property.type);
          if (role != skipped) fields[static_cast<std::size_t>(role)] = value;
          continue;
        }
        const double length = source.value(*property.list_count);
        if (length < 0) throw source.error(instance(element, i) + " has a list of negative length");
        for (auto k = static_cast<std::size_t>(length); k > 0; --k) {
          const double value = source.value(property.type);
          if (role == corners) face.push_back(value);
        }
      }
      source.finish();

      if (is_vertex) {
        const std::size_t used = layout.has_normals ? 6 : 3;
        for (std::size_t f = 0; f < used; ++f) {
          if (!std::isfinite(fields[f])) {
            throw source.error(instance(element, i) + " has a non-finite value (" + std::to_string(fields[f]) + ")");
          }
        }
        body.points.insert(body.points.end(), fields.begin(), fields.begin() + 3);
        if (layout.has_normals) body.normals.insert(body.normals.end(), fields.begin() + 3, fields.end());
      } else if (is_face) {
        if (face.size() < 3) {
          throw source.error(instance(element, i) + " has " + std::to_string(face.size()) +
                             " vertex indices; a face needs at least 3");
        }
        for (const double corner : face) {
          if (corner < 0 || corner >= static_cast<double>(vertex_count)) {
            throw source.error(instance(element, i) + " has vertex index " +
                               std::to_string(static_cast<long long>(corner)) + ", but the file has " +
                               std::to_string(vertex_count) + " vertices");
          }
        }
        if (face.size() > 3) ++body.polygons;
        for (std::size_t k = 1; k + 1 < face.size(); ++k) {
          for (const double corner : {face[0], face[k], face[k + 1]}) {
            body.triangles.push_back(static_cast<int>(corner));
          }
        }
      }
    }
  }
  source.end();
  return body;
}

Points rows_of(const std::vector<double>& values) {
  return Eigen::Map<const Points>(values.data(), static_cast<Eigen::Index>(values.size() / 3), 3);
}

void append_binary(std::string& out, std::uint64_t bits, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>(bits >> (8 * i)));
}

void write(std::ostream& out, const Points& points, const Points& normals, const Triangles* faces,
           PlyEncoding encoding) {
  const bool ascii = encoding == PlyEncoding::ascii;
  const bool with_normals = normals.rows() > 0 && normals.rows() == points.rows();
  std::string text = ascii ? "ply\nformat ascii 1.0\n" : "ply\nformat binary_little_endian 1.0\n";
  text += "element vertex " + std::to_string(points.rows()) + "\n";
  text += "property double x\nproperty double y\nproperty double z\n";
  if (with_normals) text += "property double nx\nproperty double ny\nproperty double nz\n";
  if (faces != nullptr) {
    text += "element face " + std::to_string(faces->rows()) + "\nproperty list uchar int vertex_indices\n";
  }
  text += "end_header\n";

  const auto put_row = [&](const auto& row) {
    for (Eigen::Index k = 0; k < 3; ++k) {
      if (!ascii) {
        append_binary(text, std::bit_cast<std::uint64_t>(row[k]), 8);
        continue;
      }
      if (text.back() != '\n') text += ' ';
      append_number(text, row[k]);
    }
  };
  for (Eigen::Index v = 0; v < points.rows(); ++v) {
    put_row(points.row(v));
    if (with_normals) put_row(normals.row(v));
    if (ascii) text += '\n';
  }
  for (Eigen::Index f = 0; faces != nullptr && f < faces->rows(); ++f) {
    text += ascii ? '3' : '\3';
    for (Eigen::Index k = 0; k < 3; ++k) {
      const int corner = (*faces)(f, k);
      if (ascii) {
        text += ' ';
        append_number(text, corner);
      } else {
        append_binary(text, static_cast<std::uint32_t>(corner), 4);
      }
    }
    if (ascii) text += '\n';
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

}  // namespace

ReadResult read_ply(const std::filesystem::path& file, std::string_view bytes) {
  TextScanner text(file, bytes);
  const Header header = read_header(file, bytes, text);
  Body body;
  if (header.encoding == Encoding::ascii) {
    AsciiBody source(file, text);
    body = read_body(file, header, bytes.size(), source);
  } else {
    BinaryBody source(file, bytes, text.offset(), header.encoding);
    body = read_body(file, header, bytes.size(), source);
  }

  ReadReport report;
  report.vertices_read = body.points.size() / 3;
  report.faces_read = body.triangles.size() / 3;
  report.polygons_triangulated = body.polygons;
  if (body.triangles.empty()) return {PointCloud{rows_of(body.points), rows_of(body.normals)}, report};
  TriangleMesh mesh{
      rows_of(body.points),
      Eigen::Map<const Triangles>(body.triangles.data(), static_cast<Eigen::Index>(body.triangles.size() / 3), 3),
      rows_of(body.normals)};
  return {std::move(mesh), report};
}

void write_ply(std::ostream& out, const TriangleMesh& mesh, PlyEncoding encoding) {
  write(out, mesh.vertices, mesh.vertex_normals, &mesh.faces, encoding);
}

void write_ply(std::ostream& out, const PointCloud& cloud, PlyEncoding encoding) {
  write(out, cloud.points, cloud.normals, nullptr, encoding);
}

}  // namespace cmm::geometry
