// See json_fields.hpp.
#include "planner/json_fields.hpp"

#include <cmath>

#include "geometry/file_error.hpp"

namespace cmm::planner {

// "corners[1].scan.y" → "/corners/1/scan/1". The readers name a vector's elements x, y, z and no
// key of theirs is x, y or z or holds '.', '[', '~' or '/', so this mapping is exact for them.
std::string json_pointer(const std::string& field) {
  std::string pointer;
  std::string part;
  auto flush = [&] {
    if (part == "x" || part == "y" || part == "z") part = std::to_string(part[0] - 'x');
    pointer += "/" + part;
    part.clear();
  };
  for (const char c : field) {
    if (c == '.' || c == '[') flush();
    else if (c != ']') part += c;
  }
  if (!field.empty()) flush();
  return pointer;
}

void fail_field(const std::string& source, const std::string& field, const std::string& message) {
  throw geometry::FileError::at_field(source, field, json_pointer(field), message);
}

double number(const nlohmann::json& j, const std::string& source, const std::string& field) {
  if (!j.is_number()) fail_field(source, field, "expected a number, got " + j.dump());
  const double value = j.get<double>();
  if (!std::isfinite(value)) fail_field(source, field, "not a finite number");
  return value;
}

double positive(const nlohmann::json& j, const std::string& source, const std::string& field) {
  const double value = number(j, source, field);
  if (!(value > 0)) fail_field(source, field, "must be positive, got " + j.dump());
  return value;
}

int integer(const nlohmann::json& j, const std::string& source, const std::string& field, int min, int max) {
  const std::string range = "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
  if (!j.is_number_integer()) fail_field(source, field, "expected " + range + ", got " + j.dump());
  const bool fits = j.is_number_unsigned() ? j.get<std::uint64_t>() <= static_cast<std::uint64_t>(max)
                                           : j.get<std::int64_t>() >= min && j.get<std::int64_t>() <= max;
  if (!fits) fail_field(source, field, "expected " + range + ", got " + j.dump());
  return j.get<int>();
}

void only_known_keys(const nlohmann::json& j, const std::string& source, const std::string& field,
                     const std::set<std::string>& known) {
  for (const auto& [key, value] : j.items()) {
    if (known.count(key)) continue;
    std::string list;
    for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
    fail_field(source, field.empty() ? key : field + "." + key, "unknown field (known: " + list + ")");
  }
}

}  // namespace cmm::planner
