// The header is text in every encoding and is checked whole before the data is touched: its counts
// must describe exactly the bytes that follow, so no hostile count makes the reader allocate or loop
// beyond what the file holds. The data is then read point by point into one set of x y z (and normal)
// values, whatever the encoding: ASCII lines, packed binary records, or LZF-compressed columns.
#include "geometry/pcd_io.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/file_error.hpp"
#include "geometry/lzf.hpp"
#include "geometry/text_io.hpp"

namespace cmm::geometry {

namespace {

enum class Data { ascii, binary, binary_compressed };

// What a field is read into: x y z, the normal's components, or nothing.
constexpr int skipped = -1;
constexpr std::array<std::string_view, 6> roles{"x", "y", "z", "normal_x", "normal_y", "normal_z"};

struct Field {
  std::string name;
  std::size_t size = 0;   // bytes of one value
  char type = 'F';        // F float, I signed, U unsigned
  std::size_t count = 1;  // values per point
  std::size_t offset = 0;  // of its first value in a packed record
  int role = skipped;
};

struct Header {
  std::vector<Field> fields;
  std::size_t width = 0, height = 1, points = 0;
  std::array<double, 7> viewpoint{0, 0, 0, 1, 0, 0, 0};  // tx ty tz qw qx qy qz
  Data data = Data::ascii;
  std::size_t point_size = 0;    // bytes of a packed record
  std::size_t values = 0;        // values per point (an ASCII line's tokens)
  bool has_normals = false;
  std::size_t points_line = 0;   // where a wrong count is reported: POINTS, else WIDTH
  std::size_t data_offset = 0;   // first byte after the DATA line
};

// The header's lines by keyword, each at most once; checked together once DATA ends the header.
struct HeaderLines {
  struct Line {
    std::size_t number = 0;
    std::vector<std::string_view> values;  // the tokens after the keyword
  };
  std::optional<Line> version, fields, size, type, count, width, height, viewpoint, points, data;
};

// A header value as a number: the whole token, as std::from_chars reads it; nullopt when it is not one.
template <class Number>
std::optional<Number> number_of(std::string_view token) {
  Number value{};
  const auto [end, status] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (status != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

HeaderLines read_header_lines(TextScanner& text) {
  HeaderLines lines;
  const auto keywords = "VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS or DATA";
  for (;;) {
    if (!text.next_line()) throw text.error("file ends here; the header has no DATA line");
    const auto& tokens = text.tokens();
    const std::string_view keyword = tokens[0];
    std::optional<HeaderLines::Line>* slot = nullptr;
    if (keyword == "VERSION") slot = &lines.version;
    else if (keyword == "FIELDS" || keyword == "COLUMNS") slot = &lines.fields;  // COLUMNS: PCD 0.5
    else if (keyword == "SIZE") slot = &lines.size;
    else if (keyword == "TYPE") slot = &lines.type;
    else if (keyword == "COUNT") slot = &lines.count;
    else if (keyword == "WIDTH") slot = &lines.width;
    else if (keyword == "HEIGHT") slot = &lines.height;
    else if (keyword == "VIEWPOINT") slot = &lines.viewpoint;
    else if (keyword == "POINTS") slot = &lines.points;
    else if (keyword == "DATA") slot = &lines.data;
    else throw text.error("unexpected " + in_quotes(keyword) + " in the header; expected " + keywords);
    if (*slot)
      throw text.error("a second " + std::string(keyword) + " line (the first is line " +
                       std::to_string((*slot)->number) + ")");
    if (tokens.size() < 2) throw text.error(std::string(keyword) + " without a value");
    *slot = HeaderLines::Line{text.line_number(), {tokens.begin() + 1, tokens.end()}};
    if (keyword == "DATA") return lines;
  }
}

Header read_header(const std::filesystem::path& file, std::string_view bytes, TextScanner& text) {
  const HeaderLines lines = read_header_lines(text);
  const std::size_t data_line = lines.data->number;
  const auto at = [&](std::size_t line, const std::string& message) { return FileError::at_line(file, line, message); };
  const auto one_value = [&](const HeaderLines::Line& line, const char* keyword) {
    if (line.values.size() != 1) throw at(line.number, std::string(keyword) + " takes one value");
    return line.values[0];
  };
  // Every count is compared against the file's size, the one bound a real file keeps.
  const std::size_t file_size = bytes.size();
  Header h;

  if (lines.version) {
    const std::string_view v = one_value(*lines.version, "VERSION");
    if (v != "0.7" && v != ".7" && v != "0.6" && v != ".6" && v != "0.5" && v != ".5")
      throw at(lines.version->number, "unsupported PCD version " + in_quotes(v) + "; expected 0.5, 0.6 or 0.7");
  }
  const std::string_view data = one_value(*lines.data, "DATA");
  if (data == "ascii") h.data = Data::ascii;
  else if (data == "binary") h.data = Data::binary;
  else if (data == "binary_compressed") h.data = Data::binary_compressed;
  else throw at(data_line, "unknown DATA " + in_quotes(data) + "; expected ascii, binary or binary_compressed");

  if (!lines.fields) throw at(data_line, "the header has no FIELDS line");
  if (!lines.size) throw at(data_line, "the header has no SIZE line");
  if (!lines.type) throw at(data_line, "the header has no TYPE line");
  const std::size_t n = lines.fields->values.size();
  for (const auto& [line, keyword] : {std::pair{&lines.size, "SIZE"}, {&lines.type, "TYPE"}, {&lines.count, "COUNT"}}) {
    if (*line && (*line)->values.size() != n)
      throw at((*line)->number, std::string(keyword) + " has " + std::to_string((*line)->values.size()) +
                                    " entries but FIELDS (line " + std::to_string(lines.fields->number) + ") has " +
                                    std::to_string(n));
  }
  std::array<bool, roles.size()> found{};
  for (std::size_t f = 0; f < n; ++f) {
    Field field;
    field.name = std::string(lines.fields->values[f]);
    const std::string_view size = lines.size->values[f], type = lines.type->values[f];
    if (size != "1" && size != "2" && size != "4" && size != "8")
      throw at(lines.size->number, "field " + in_quotes(field.name) + " has SIZE " + in_quotes(size) + "; expected 1, 2, 4 or 8");
    field.size = static_cast<std::size_t>(size[0] - '0');
    if (type != "F" && type != "I" && type != "U")
      throw at(lines.type->number, "field " + in_quotes(field.name) + " has TYPE " + in_quotes(type) + "; expected F, I or U");
    field.type = type[0];
    if (field.type == 'F' && field.size != 4 && field.size != 8)
      throw at(lines.size->number, "field " + in_quotes(field.name) + " is a float of " + std::to_string(field.size) +
                                       " bytes; a PCD float has 4 or 8");
    if (lines.count) {
      // A value takes at least a byte in every encoding: more per point than the file has is a lie.
      const std::string_view count = lines.count->values[f];
      const std::optional<long long> value = number_of<long long>(count);
      if (!value || *value < 1 || static_cast<unsigned long long>(*value) > file_size)
        throw at(lines.count->number, "field " + in_quotes(field.name) + " has COUNT " + in_quotes(count) +
                                          "; expected an integer from 1 to " + std::to_string(file_size) + " (the file's size)");
      field.count = static_cast<std::size_t>(*value);
    }
    field.offset = h.point_size;
    h.point_size += field.size * field.count;
    h.values += field.count;
    // No encoding packs a point into fewer bytes than LZF's best (ASCII spends at least a byte a
    // value, binary its size); checked as the sum grows, so it cannot overflow either.
    if (h.point_size > file_size * lzf_max_expansion)
      throw at(lines.size->number, "a point of " + std::to_string(h.point_size) +
                                       " bytes or more: more than the whole file could hold (" +
                                       std::to_string(file_size) + " bytes)");
    if (const auto role = std::find(roles.begin(), roles.end(), field.name); role != roles.end()) {
      const auto r = static_cast<std::size_t>(role - roles.begin());
      if (found[r]) throw at(lines.fields->number, "field " + in_quotes(field.name) + " appears twice");
      if (field.count != 1)
        throw at(lines.count->number, "field " + in_quotes(field.name) + " has COUNT " + std::to_string(field.count) +
                                          "; a coordinate or normal component has 1");
      found[r] = true;
      field.role = static_cast<int>(r);
    }
    h.fields.push_back(std::move(field));
  }
  if (!found[0] || !found[1] || !found[2]) throw at(lines.fields->number, "FIELDS lacks one of x, y, z");
  h.has_normals = found[3] && found[4] && found[5];
  if (!h.has_normals)
    for (Field& field : h.fields)
      if (field.role >= 3) field.role = skipped;  // a normal without all three components is none

  // WIDTH × HEIGHT = POINTS; a 0.5 file may give POINTS alone.
  const auto whole = [&](const HeaderLines::Line& line, const char* keyword, std::size_t max) {
    const std::string_view token = one_value(line, keyword);
    const std::optional<unsigned long long> value = token.starts_with('-') ? std::nullopt : number_of<unsigned long long>(token);
    if (!value || *value > max)
      throw at(line.number, std::string(keyword) + " " + in_quotes(token) + " is not a count from 0 to " + std::to_string(max));
    return static_cast<std::size_t>(*value);
  };
  if (lines.width) h.width = whole(*lines.width, "WIDTH", file_size);
  if (lines.height) h.height = whole(*lines.height, "HEIGHT", file_size);
  if (lines.points) h.points = whole(*lines.points, "POINTS", std::numeric_limits<std::size_t>::max() / 2);
  if (!lines.width && !lines.points) throw at(data_line, "the header has no WIDTH and no POINTS line");
  if (!lines.width) h.width = h.points;
  const std::size_t width_line = lines.width ? lines.width->number : lines.points->number;
  if (h.height != 0 && h.width > std::numeric_limits<std::size_t>::max() / 2 / h.height)
    throw at(width_line, "WIDTH × HEIGHT overflows");
  if (!lines.points) h.points = h.width * h.height;
  h.points_line = lines.points ? lines.points->number : width_line;
  if (h.points != h.width * h.height)
    throw at(h.points_line, "POINTS " + std::to_string(h.points) + " is not WIDTH × HEIGHT (" + std::to_string(h.width) +
                                " × " + std::to_string(h.height) + ")");

  if (lines.viewpoint) {
    if (lines.viewpoint->values.size() != 7)
      throw at(lines.viewpoint->number, "VIEWPOINT takes 7 values: tx ty tz qw qx qy qz");
    for (std::size_t k = 0; k < 7; ++k) {
      const std::string_view token = lines.viewpoint->values[k];
      const std::optional<double> value = number_of<double>(token);
      if (!value || !std::isfinite(*value))
        throw at(lines.viewpoint->number, "VIEWPOINT value " + in_quotes(token) + " is not a finite number");
      h.viewpoint[k] = *value;
    }
    const double norm = std::hypot(std::hypot(h.viewpoint[3], h.viewpoint[4]), std::hypot(h.viewpoint[5], h.viewpoint[6]));
    if (!(norm > 1e-9)) throw at(lines.viewpoint->number, "VIEWPOINT's quaternion qw qx qy qz is zero");
  }
  h.data_offset = text.offset();
  return h;
}

double decode(const char* at, const Field& field) {
  const auto get = [at]<class T>(T value) {
    std::memcpy(&value, at, sizeof value);  // PCD binary is little endian, as every PCL host is
    if constexpr (std::endian::native == std::endian::big) {
      auto raw = std::bit_cast<std::array<unsigned char, sizeof(T)>>(value);
      std::reverse(raw.begin(), raw.end());
      value = std::bit_cast<T>(raw);
    }
    return static_cast<double>(value);
  };
  switch (field.type) {
    case 'F': return field.size == 4 ? get(float{}) : get(double{});
    case 'I':
      switch (field.size) {
        case 1: return get(std::int8_t{});
        case 2: return get(std::int16_t{});
        case 4: return get(std::int32_t{});
        default: return get(std::int64_t{});
      }
    default:
      switch (field.size) {
        case 1: return get(std::uint8_t{});
        case 2: return get(std::uint16_t{});
        case 4: return get(std::uint32_t{});
        default: return get(std::uint64_t{});
      }
  }
}

std::uint32_t u32_at(std::string_view bytes, std::size_t offset) {
  std::uint32_t value = 0;
  for (int k = 3; k >= 0; --k) value = (value << 8) | static_cast<unsigned char>(bytes[offset + static_cast<std::size_t>(k)]);
  return value;
}

// The points as they are kept: x y z and normals; organized pixels without a return left out.
class Collector {
 public:
  explicit Collector(const Header& header, std::size_t plausible) : header_(header) {
    points_.reserve(3 * plausible);
    if (header.has_normals) normals_.reserve(3 * plausible);
  }

  // `values` by role; `error` builds the FileError naming where point `index` is.
  template <class Error>
  void take(std::size_t index, const std::array<double, 6>& values, const Error& error) {
    const bool organized = header_.height > 1;
    if (organized && (std::isnan(values[0]) || std::isnan(values[1]) || std::isnan(values[2]))) {
      ++without_return_;
      return;
    }
    const std::size_t used = header_.has_normals ? 6 : 3;
    for (std::size_t k = 0; k < used; ++k) {
      if (std::isfinite(values[k])) continue;
      std::string message = "point " + std::to_string(index) + " has " + std::string(roles[k]) + " " +
                            (std::isnan(values[k]) ? "nan" : values[k] > 0 ? "inf" : "-inf");
      if (k < 3 && std::isnan(values[k]))
        message += organized ? "" : " (NaN marks a missing return only in an organized cloud, HEIGHT > 1)";
      throw error(message);
    }
    points_.insert(points_.end(), values.begin(), values.begin() + 3);
    if (header_.has_normals) normals_.insert(normals_.end(), values.begin() + 3, values.end());
  }

  ReadResult result() const {
    PointCloud cloud{rows_of(points_), rows_of(normals_)};
    ReadReport report;
    report.vertices_read = points_.size() / 3;
    report.points_without_return = without_return_;
    const auto& v = header_.viewpoint;
    if (v != std::array<double, 7>{0, 0, 0, 1, 0, 0, 0}) {
      // Sensor frame to the cloud's frame: p' = R p + t, normals turned by R alone.
      const Eigen::Matrix3d R = Eigen::Quaterniond(v[3], v[4], v[5], v[6]).normalized().toRotationMatrix();
      const Eigen::RowVector3d t(v[0], v[1], v[2]);
      cloud.points = (cloud.points * R.transpose()).rowwise() + t;
      if (cloud.normals.rows() > 0) cloud.normals = cloud.normals * R.transpose();
      report.viewpoint_applied = true;
    }
    return {std::move(cloud), report};
  }

 private:
  static Points rows_of(const std::vector<double>& values) {
    return Eigen::Map<const Points>(values.data(), static_cast<Eigen::Index>(values.size() / 3), 3);
  }

  const Header& header_;
  std::vector<double> points_, normals_;
  std::size_t without_return_ = 0;
};

// A double narrowed to float without undefined behaviour: beyond float's range is an infinity.
float narrowed(double value) {
  constexpr float infinity = std::numeric_limits<float>::infinity();
  if (std::abs(value) > std::numeric_limits<float>::max()) return value > 0 ? infinity : -infinity;
  return static_cast<float>(value);
}

// A float field's text as PCL reads it, to the nearest float (read as a float, not rounded twice
// through a double); `value` is the token read as a double.
double as_float(std::string_view token, double value) {
  if (token.starts_with('+')) token.remove_prefix(1);
  float single = 0;
  const auto [end, status] = std::from_chars(token.data(), token.data() + token.size(), single);
  return status == std::errc() && end == token.data() + token.size() ? single : narrowed(value);
}

ReadResult read_ascii(const std::filesystem::path& file, std::string_view bytes, const Header& h, TextScanner& text) {
  // A point's line holds at least one byte per value and its newline.
  Collector collector(h, std::min(h.points, bytes.size() / (h.values + 1)));
  for (std::size_t i = 0; i < h.points; ++i) {
    if (!text.next_line())
      throw FileError::at_line(file, h.points_line,
                               "the header announces " + std::to_string(h.points) + " points but the data ends after " +
                                   std::to_string(i));
    const auto& tokens = text.tokens();
    if (tokens.size() != h.values)
      throw text.error("point " + std::to_string(i) + " has " + std::to_string(tokens.size()) + " values; the fields take " +
                       std::to_string(h.values));
    std::array<double, 6> values{};
    std::size_t token = 0;
    for (const Field& field : h.fields) {
      for (std::size_t k = 0; k < field.count; ++k, ++token) {
        double value = text.number(tokens[token]);  // NaN and inf too: take() judges them
        if (field.type == 'F' && field.size == 4) value = as_float(tokens[token], value);
        if (field.role != skipped) values[static_cast<std::size_t>(field.role)] = value;
      }
    }
    collector.take(i, values, [&](const std::string& message) { return text.error(message); });
  }
  if (text.next_line()) throw text.error("data after the last point the header announces");
  return collector.result();
}

// PCL stretches a binary file by a page of zeros past its data (pcl::PCDWriter maps a page more than it
// writes): zeros after the data are that padding; anything else there is data the header does not count.
void check_padding(const std::filesystem::path& file, std::string_view bytes, std::size_t end, const char* after) {
  const std::size_t junk = bytes.find_first_not_of('\0', end);
  if (junk != std::string_view::npos)
    throw FileError::at_byte(file, junk, std::to_string(bytes.size() - end) + " bytes after " + after +
                                             ", and not the zeros PCL pads a file with");
}

ReadResult read_binary(const std::filesystem::path& file, std::string_view bytes, const Header& h) {
  const std::size_t start = h.data_offset, available = bytes.size() - start;
  // point_size <= file size and points <= SIZE_MAX / 2, so this only overflows for a lie; compared by division.
  const std::size_t fitting = available / h.point_size;
  if (fitting < h.points)
    throw FileError::at_byte(file, start + fitting * h.point_size,
                             "truncated: the header announces " + std::to_string(h.points) + " points of " +
                                 std::to_string(h.point_size) + " bytes but the data holds " + std::to_string(fitting) +
                                 " (" + std::to_string(available) + " bytes)");
  check_padding(file, bytes, start + h.points * h.point_size, "the last point the header announces");
  Collector collector(h, h.points);
  for (std::size_t i = 0; i < h.points; ++i) {
    const std::size_t record = start + i * h.point_size;
    std::array<double, 6> values{};
    for (const Field& field : h.fields)
      if (field.role != skipped) values[static_cast<std::size_t>(field.role)] = decode(bytes.data() + record + field.offset, field);
    collector.take(i, values, [&](const std::string& message) { return FileError::at_byte(file, record, message); });
  }
  return collector.result();
}

// binary_compressed: two little-endian uint32 (compressed and uncompressed size), then the LZF block;
// uncompressed, each field's values of all points lie together, field after field.
ReadResult read_compressed(const std::filesystem::path& file, std::string_view bytes, const Header& h) {
  const std::size_t start = h.data_offset;
  if (bytes.size() - start < 8)
    throw FileError::at_byte(file, start, "truncated: binary_compressed data starts with two 4-byte sizes");
  const std::size_t compressed = u32_at(bytes, start), size = u32_at(bytes, start + 4);
  const std::size_t block = start + 8;
  if (bytes.size() - block < compressed)
    throw FileError::at_byte(file, start, "truncated: the compressed block of " + std::to_string(compressed) +
                                              " bytes runs past the end of the file (" + std::to_string(bytes.size()) + " bytes)");
  check_padding(file, bytes, block + compressed, "the compressed block");
  if (h.points > size / h.point_size || h.points * h.point_size != size)
    throw FileError::at_byte(file, start + 4, "the compressed block holds " + std::to_string(size) + " bytes, but " +
                                                  std::to_string(h.points) + " points of " + std::to_string(h.point_size) +
                                                  " bytes take " + (h.points > size / h.point_size ? std::string("more") : std::to_string(h.points * h.point_size)));
  std::string columns;
  try {
    columns = lzf_decompress(bytes.substr(block, compressed), size);
  } catch (const LzfError& e) {
    throw FileError::at_byte(file, block + e.offset, std::string("bad LZF data: ") + e.what());
  }
  Collector collector(h, h.points);
  for (std::size_t i = 0; i < h.points; ++i) {
    std::array<double, 6> values{};
    for (const Field& field : h.fields) {
      if (field.role == skipped) continue;
      // Fields before this one take points × their size; this one's value i is i sizes in.
      const std::size_t column = field.offset * h.points;
      values[static_cast<std::size_t>(field.role)] = decode(columns.data() + column + i * field.size, field);
    }
    collector.take(i, values, [&](const std::string& message) {
      return FileError::at_byte(file, block, message + " (in the decompressed data)");
    });
  }
  return collector.result();
}

void append_binary(std::string& out, const void* value, std::size_t size) {
  out.append(static_cast<const char*>(value), size);  // little endian, as PCL writes
}

}  // namespace

ReadResult read_pcd(const std::filesystem::path& file, std::string_view bytes) {
  TextScanner text(file, bytes, '#');
  const Header header = read_header(file, bytes, text);
  switch (header.data) {
    case Data::ascii: return read_ascii(file, bytes, header, text);
    case Data::binary: return read_binary(file, bytes, header);
    case Data::binary_compressed: return read_compressed(file, bytes, header);
  }
  return {};
}

void write_pcd(std::ostream& out, const PointCloud& cloud, PcdEncoding encoding, PcdScalar scalar) {
  static_assert(std::endian::native == std::endian::little, "PCD binary is little endian");
  const bool with_normals = cloud.normals.rows() > 0 && cloud.normals.rows() == cloud.points.rows();
  const int columns = with_normals ? 6 : 3;
  const bool single = scalar == PcdScalar::float32;
  const std::string n = std::to_string(cloud.points.rows());
  const std::string sizes = single ? " 4 4 4" : " 8 8 8";
  std::string text = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z";
  text += with_normals ? " normal_x normal_y normal_z\nSIZE" + sizes + sizes : "\nSIZE" + sizes;
  text += with_normals ? "\nTYPE F F F F F F\nCOUNT 1 1 1 1 1 1\n" : "\nTYPE F F F\nCOUNT 1 1 1\n";
  text += "WIDTH " + n + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n + "\n";
  text += encoding == PcdEncoding::ascii ? "DATA ascii\n" : "DATA binary\n";
  for (Eigen::Index v = 0; v < cloud.points.rows(); ++v) {
    for (int k = 0; k < columns; ++k) {
      const double value = k < 3 ? cloud.points(v, k) : cloud.normals(v, k - 3);
      const float narrow = narrowed(value);
      if (encoding == PcdEncoding::binary) {
        single ? append_binary(text, &narrow, 4) : append_binary(text, &value, 8);
        continue;
      }
      if (k > 0) text += ' ';
      single ? append_number(text, narrow) : append_number(text, value);
    }
    if (encoding == PcdEncoding::ascii) text += '\n';
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

}  // namespace cmm::geometry
