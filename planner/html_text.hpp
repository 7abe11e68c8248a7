// Text for the HTML and SVG the report writes: escaping of anything that came from outside (job
// names are user input) and joining pieces by appending (GCC 12 -O3 warns falsely, -Wrestrict,
// on "literal" + std::string&&).
#pragma once

#include <string>
#include <string_view>

namespace cmm::planner {

// Safe in element content and in quoted attribute values.
inline std::string escape_html(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

template <class... Parts>
std::string concat(const Parts&... parts) {
  std::string out;
  (out += ... += parts);
  return out;
}

}  // namespace cmm::planner
