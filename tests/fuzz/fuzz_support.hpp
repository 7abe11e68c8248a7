// What the harnesses share: the input as text or JSON, and the one rule of every target: a refusal
// is one of the project's typed errors, anything else that escapes is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace cmm::fuzz {

inline std::string_view text_of(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Runs f; an exception of one of the Refusals is the parser saying no and goes quietly. Any other
// exception propagates out of LLVMFuzzerTestOneInput, which libFuzzer reports as a crash.
template <class F>
void refusing_with(F&& f) {
  f();
}
template <class Refusal, class... Others, class F>
void refusing_with(F&& f) {
  try {
    refusing_with<Others...>(f);
  } catch (const Refusal&) {
  }
}

// The bytes as a file reader of the project would parse them (read_machine, read_plate,
// read_registration, read_daemon_config: json::parse, every json::exception a FieldError);
// nullopt where that reader refuses, so the harness goes on only with JSON.
inline std::optional<nlohmann::json> json_of(std::string_view text) {
  nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) return std::nullopt;
  return j;
}

// Inputs that name files are read from disk by the code under test (a plate by path, a machine
// description by path). A file under /dev, /proc or /sys may never end (/dev/zero) or block
// (/dev/stdin): that is the operator's choice of file, not a parser bug, so the harnesses skip JSON
// with a string that could reach one (decoded, so "\u0064ev" counts too).
inline bool names_special_file(const nlohmann::json& j) {
  if (j.is_string()) {
    const auto& s = j.get_ref<const std::string&>();
    return s.find("dev") != std::string::npos || s.find("proc") != std::string::npos ||
           s.find("sys") != std::string::npos || s.find("fd") != std::string::npos;
  }
  if (j.is_object())
    for (const auto& [key, value] : j.items())
      if (names_special_file(value)) return true;
  if (j.is_array())
    for (const auto& value : j)
      if (names_special_file(value)) return true;
  return false;
}

}  // namespace cmm::fuzz
