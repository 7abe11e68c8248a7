// Shared by the text formats (ASCII STL and PLY, OBJ, OFF, XYZ): numbered lines and tokens for the
// readers, so every error names its line, and shortest exact numbers for the writers.
#pragma once

#include <charconv>
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "geometry/file_error.hpp"

namespace cmm::geometry {

class TextScanner {
 public:
  // `comment` starts a comment running to the end of the line ('\0': none); XYZ also splits on commas.
  TextScanner(const std::filesystem::path& file, std::string_view text, char comment = '\0',
              bool comma_separates = false);

  // Moves to the next line holding a token; false at the end, where line_number() stays on the last line.
  bool next_line();
  const std::vector<std::string_view>& tokens() const { return tokens_; }
  std::size_t line_number() const { return line_; }
  // Byte just past the current line: where a binary PLY body starts after "end_header".
  std::size_t offset() const { return offset_; }

  FileError error(const std::string& message) const { return FileError::at_line(file_, line_, message); }
  // Any double, NaN and infinity included: callers check finiteness where it matters.
  double number(std::string_view token) const;
  // A coordinate or normal component: finite, else an error on this line.
  double finite(std::string_view token) const;
  long long integer(std::string_view token) const;

 private:
  std::filesystem::path file_;
  std::string_view text_;
  char comment_;
  bool comma_separates_;
  std::size_t offset_ = 0;
  std::size_t line_ = 0;
  std::vector<std::string_view> tokens_;
};

// A token as it appears in an error message: quoted, and cut short if it is a run of binary junk.
std::string in_quotes(std::string_view token);

// Shortest text that reads back to the same value (std::to_chars), so text round trips are exact.
template <class Number>
void append_number(std::string& out, Number value) {
  char buffer[32];
  const auto end = std::to_chars(buffer, buffer + sizeof buffer, value).ptr;
  out.append(buffer, end);
}

}  // namespace cmm::geometry
