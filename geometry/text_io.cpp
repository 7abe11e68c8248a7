// Line and token scanning for the text formats; numbers go through std::from_chars (no locale, fast).
#include "geometry/text_io.hpp"

#include <cmath>

namespace cmm::geometry {

TextScanner::TextScanner(const std::filesystem::path& file, std::string_view text, char comment, bool comma_separates)
    : file_(file), text_(text), comment_(comment), comma_separates_(comma_separates) {}

bool TextScanner::next_line() {
  tokens_.clear();
  while (tokens_.empty() && offset_ < text_.size()) {
    const std::size_t newline = text_.find('\n', offset_);
    std::string_view line = text_.substr(offset_, newline - offset_);
    offset_ = newline == std::string_view::npos ? text_.size() : newline + 1;
    ++line_;
    if (comment_ != '\0') line = line.substr(0, line.find(comment_));
    const auto separates = [&](char c) {
      return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f' || (comma_separates_ && c == ',');
    };
    for (std::size_t i = 0; i < line.size();) {
      if (separates(line[i])) {
        ++i;
        continue;
      }
      std::size_t end = i;
      while (end < line.size() && !separates(line[end])) ++end;
      tokens_.push_back(line.substr(i, end - i));
      i = end;
    }
  }
  return !tokens_.empty();
}

namespace {

// from_chars rejects a leading '+', which some exporters write.
std::string_view without_plus(std::string_view token) {
  return token.size() > 1 && token[0] == '+' && token[1] != '-' ? token.substr(1) : token;
}

}  // namespace

double TextScanner::number(std::string_view token) const {
  const std::string_view digits = without_plus(token);
  double value = 0;
  const auto [end, status] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (status != std::errc() || end != digits.data() + digits.size()) {
    throw error(in_quotes(token) + " is not a number");
  }
  return value;
}

double TextScanner::finite(std::string_view token) const {
  const double value = number(token);
  if (!std::isfinite(value)) throw error(in_quotes(token) + " is not a finite number");
  return value;
}

long long TextScanner::integer(std::string_view token) const {
  const std::string_view digits = without_plus(token);
  long long value = 0;
  const auto [end, status] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (status != std::errc() || end != digits.data() + digits.size()) {
    throw error(in_quotes(token) + " is not an integer");
  }
  return value;
}

std::string in_quotes(std::string_view token) {
  constexpr std::size_t shown = 32;
  std::string quoted = "'";
  quoted.append(token.substr(0, shown)).append(token.size() > shown ? "...'" : "'");
  return quoted;
}

}  // namespace cmm::geometry
