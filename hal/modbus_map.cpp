// Register packing for the Modbus map, and the map as Markdown for docs/modbus-map.md.
#include "hal/modbus_map.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace cmm::hal::modbus {

std::uint16_t to_code(FaultKind kind) { return static_cast<std::uint16_t>(static_cast<int>(kind) + 1); }

FaultKind fault_from_code(std::uint16_t code) {
  if (code < 1 || code > static_cast<int>(FaultKind::aborted) + 1)
    throw Protocol("unknown fault code " + std::to_string(code) + " from the machine");
  return static_cast<FaultKind>(code - 1);
}

void put_u32(std::uint16_t* regs, std::uint32_t value) {
  regs[0] = static_cast<std::uint16_t>(value >> 16);
  regs[1] = static_cast<std::uint16_t>(value & 0xffffu);
}
void put_i32(std::uint16_t* regs, std::int32_t value) { put_u32(regs, static_cast<std::uint32_t>(value)); }
std::uint32_t get_u32(const std::uint16_t* regs) { return (std::uint32_t{regs[0]} << 16) | regs[1]; }
std::int32_t get_i32(const std::uint16_t* regs) { return static_cast<std::int32_t>(get_u32(regs)); }

void put_ascii(std::uint16_t* regs, int count, std::string_view text) {
  for (int i = 0; i < count; ++i) {
    auto at = [&](std::size_t k) { return k < text.size() ? static_cast<unsigned char>(text[k]) : 0u; };
    regs[i] = static_cast<std::uint16_t>((at(2 * static_cast<std::size_t>(i)) << 8) | at(2 * static_cast<std::size_t>(i) + 1));
  }
}

std::string get_ascii(const std::uint16_t* regs, int count) {
  std::string out;
  for (int i = 0; i < count; ++i)
    for (int shift : {8, 0}) {
      char c = static_cast<char>((regs[i] >> shift) & 0xff);
      if (c == 0) return out;
      out.push_back(c);
    }
  return out;
}

std::int32_t to_nm(double mm) {
  const double nm = std::round(mm * 1e6);
  if (!std::isfinite(nm) || std::abs(nm) > std::numeric_limits<std::int32_t>::max())
    throw std::out_of_range("a length of " + std::to_string(mm) + " mm does not fit the Modbus map (±2147 mm)");
  return static_cast<std::int32_t>(nm);
}

std::uint32_t to_unsigned(double value, double unit) {
  const double n = std::round(value / unit);
  if (!std::isfinite(n) || n < 0 || n > std::numeric_limits<std::uint32_t>::max())
    throw std::out_of_range("the value " + std::to_string(value) + " does not fit an unsigned Modbus register pair");
  return static_cast<std::uint32_t>(n);
}

std::string markdown_table() {
  auto type = [](Type t) {
    switch (t) {
      case Type::u16: return "u16";
      case Type::i32: return "i32";
      case Type::u32: return "u32";
      case Type::ascii: return "ascii";
    }
    return "?";
  };
  std::ostringstream out;
  out << "| address | registers | name | type | access | unit | meaning |\n";
  out << "|---:|---:|---|---|---|---|---|\n";
  for (const auto& r : kRegisters)
    out << "| " << r.address << " | " << r.count << " | `" << r.name << "` | " << type(r.type) << " | "
        << (r.access == Access::read ? "read" : "write") << " | " << r.unit << " | " << r.meaning << " |\n";
  return out.str();
}

}  // namespace cmm::hal::modbus
