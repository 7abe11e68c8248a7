// See json_fields.hpp.
#include "planner/json_fields.hpp"

#include "geometry/file_error.hpp"

namespace cmm::planner {

void fail_field(const std::string& source, const std::string& field, const std::string& message) {
  throw geometry::FileError::whole(source, field + ": " + message);
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
