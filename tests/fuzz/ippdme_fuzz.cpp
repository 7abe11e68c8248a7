// Fuzzes the I++ DME line grammar (hal/ippdme_protocol.hpp) from both sides: bytes split into lines
// as the client's reader and the server's receiver do ('\n' ends a line, a '\r' before it is
// dropped), each line read as a client command (the server's side) and as a server reply (the
// client's side). What either accepts must be finite, and must print to a line that reads back the
// same: the driver and cmm-sim compute with it and send it on.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <variant>

#include "fuzz_support.hpp"
#include "hal/ippdme_protocol.hpp"

namespace {

namespace ipp = cmm::hal::ippdme;

void check(bool ok) {
  if (!ok) __builtin_trap();
}

bool finite(const std::vector<ipp::Term>& terms) {
  for (const auto& t : terms)
    if ((t.kind == ipp::Term::Kind::number && !std::isfinite(t.number)) || !finite(t.args)) return false;
  return true;
}

void on_line(const std::string& line) {
  const auto command = ipp::parse_command(line);
  if (const auto* c = std::get_if<ipp::Command>(&command)) {
    check(finite(c->args) && c->tag.number >= 0 && c->tag.number <= 99999);
    const std::string printed = ipp::format_command(*c);
    const auto again = ipp::parse_command(printed);
    // A number too large for 9 decimals within the line limit is the only thing that may not reread.
    if (printed.size() <= ipp::kMaxLineChars) {
      check(std::holds_alternative<ipp::Command>(again));
      check(ipp::format_command(std::get<ipp::Command>(again)) == printed);
    }
    (void)ipp::vector_of(c->args, "IJK");
    (void)ipp::number_of(c->args, "X");
  } else {
    const auto& e = std::get<ipp::LineError>(command);
    (void)ipp::error_text(e.code);
  }
  if (const auto reply = ipp::parse_reply(line)) {
    check(finite(reply->data));
    (void)ipp::fault_from_error(reply->error.code);
    (void)ipp::error_text(reply->error.code);
    const std::string printed = ipp::format_reply(*reply);
    if (printed.size() <= ipp::kMaxLineChars) {
      const auto again = ipp::parse_reply(printed);
      check(again.has_value());
      check(ipp::format_reply(*again) == printed);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string partial;
  for (const char c : cmm::fuzz::text_of(data, size)) {
    if (c == '\n') {
      if (!partial.empty() && partial.back() == '\r') partial.pop_back();
      on_line(partial);
      partial.clear();
    } else {
      partial.push_back(c);
    }
  }
  return 0;
}
