// The Modbus register map of a cmmd machine: one table, read by the driver, by cmm-sim's server and
// by the generator of docs/modbus-map.md (a test proves the document is this table).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "hal/fault.hpp"

namespace cmm::hal::modbus {

// All registers are holding registers (function codes 3, 6 and 16). 32-bit values take two
// registers, high word first; text is ASCII, two characters a register, high byte first.
enum class Type { u16, i32, u32, ascii };
enum class Access { read, write };

struct Register {
  std::string_view name;
  std::uint16_t address;
  std::uint16_t count;  // registers
  Type type;
  Access access;
  std::string_view unit;  // of the value on the wire: "nm", "µm/s", "ms", …
  std::string_view meaning;
};

inline constexpr std::uint16_t kProtocolVersion = 1;
inline constexpr int kMaxTips = 8;
inline constexpr std::uint16_t kTipStride = 20;

enum Opcode : std::uint16_t { home = 1, move = 2, probe = 3, reset = 4, select_tip = 5, set_tip = 6 };
enum Urgent : std::uint16_t { stop = 1, abort = 2 };
// Bits of `flags`.
enum Flag : std::uint16_t {
  homed = 1u << 0, moving = 1u << 1, estop = 1u << 2, aborted = 1u << 3, busy = 1u << 4, heartbeat_stale = 1u << 5
};

inline constexpr std::array kRegisters = {
    // Status: read in one request while a command runs.
    Register{"protocol_version", 0, 1, Type::u16, Access::read, "", "1 for this map"},
    Register{"flags", 1, 1, Type::u16, Access::read, "bits",
             "bit 0 homed, 1 moving, 2 e-stop active, 3 abort latched, 4 busy (a command runs), 5 heartbeat went stale"},
    Register{"fault_code", 2, 1, Type::u16, Access::read, "code", "the standing fault: 0 none, else a fault code"},
    Register{"done_seq", 3, 1, Type::u16, Access::read, "",
             "sequence number of the last finished command (the machine's echo)"},
    Register{"done_result", 4, 1, Type::u16, Access::read, "code", "how that command ended: 0 done, else a fault code"},
    Register{"position_x", 5, 2, Type::i32, Access::read, "nm", "ball centre of the active tip, M"},
    Register{"position_y", 7, 2, Type::i32, Access::read, "nm", ""},
    Register{"position_z", 9, 2, Type::i32, Access::read, "nm", ""},
    Register{"clock", 11, 2, Type::u32, Access::read, "ms", "machine clock"},
    Register{"active_tip", 13, 1, Type::u16, Access::read, "index", "into the tip table"},
    Register{"touch_contact", 14, 1, Type::u16, Access::read, "", "last probe: 1 touched, 0 missed"},
    Register{"touch_x", 15, 2, Type::i32, Access::read, "nm", "last probe: ball centre at the trigger, M"},
    Register{"touch_y", 17, 2, Type::i32, Access::read, "nm", ""},
    Register{"touch_z", 19, 2, Type::i32, Access::read, "nm", ""},
    Register{"touch_travel", 21, 2, Type::u32, Access::read, "nm", "last probe: search travel to the trigger"},
    Register{"touch_clock", 23, 2, Type::u32, Access::read, "ms", "last probe: machine clock at the trigger"},
    // Machine description.
    Register{"box_min_x", 40, 2, Type::i32, Access::read, "nm", "travel box of the active tip's ball centre, M"},
    Register{"box_min_y", 42, 2, Type::i32, Access::read, "nm", ""},
    Register{"box_min_z", 44, 2, Type::i32, Access::read, "nm", ""},
    Register{"box_max_x", 46, 2, Type::i32, Access::read, "nm", ""},
    Register{"box_max_y", 48, 2, Type::i32, Access::read, "nm", ""},
    Register{"box_max_z", 50, 2, Type::i32, Access::read, "nm", ""},
    Register{"max_speed", 52, 2, Type::u32, Access::read, "µm/s", "path speed limit"},
    Register{"max_accel", 54, 2, Type::u32, Access::read, "µm/s²", "path acceleration limit"},
    Register{"probe_speed", 56, 2, Type::u32, Access::read, "µm/s", "default search speed"},
    Register{"sphere_x", 58, 2, Type::i32, Access::read, "nm", "reference sphere centre, M"},
    Register{"sphere_y", 60, 2, Type::i32, Access::read, "nm", ""},
    Register{"sphere_z", 62, 2, Type::i32, Access::read, "nm", ""},
    Register{"sphere_radius", 64, 2, Type::u32, Access::read, "nm", ""},
    Register{"tip_count", 66, 1, Type::u16, Access::read, "", "entries in the tip table (at most 8)"},
    // Tip table: entry i at 70 + 20·i; the offsets below are within an entry.
    Register{"tip_id", 70, 4, Type::ascii, Access::read, "", "tip i: id, up to 8 characters, NUL-padded"},
    Register{"tip_radius", 74, 2, Type::u32, Access::read, "nm", "tip i: ball radius (qualified, or nominal)"},
    Register{"tip_offset_x", 76, 2, Type::i32, Access::read, "nm", "tip i: ball centre from the reference point"},
    Register{"tip_offset_y", 78, 2, Type::i32, Access::read, "nm", ""},
    Register{"tip_offset_z", 80, 2, Type::i32, Access::read, "nm", ""},
    Register{"tip_qualified", 82, 2, Type::u32, Access::read, "s", "tip i: Unix time of its qualification, 0 never"},
    Register{"tip_residual", 84, 2, Type::u32, Access::read, "nm", "tip i: RMS of the qualification's sphere fit"},
    Register{"tip_touches", 86, 1, Type::u16, Access::read, "", "tip i: touches of the qualification"},
    Register{"fault_text", 300, 64, Type::ascii, Access::read, "", "the standing fault's message, NUL-padded"},
    // Command block: written whole (400–424) in one function-16 request.
    Register{"seq", 400, 1, Type::u16, Access::write, "",
             "sequence number, 1–65535, new for each command; the machine acts on a new value only"},
    Register{"opcode", 401, 1, Type::u16, Access::write, "",
             "1 home, 2 move, 3 probe, 4 reset, 5 select tip, 6 set tip (record a qualification)"},
    Register{"x", 402, 2, Type::i32, Access::write, "nm", "move: target; probe: search start; set tip: offset"},
    Register{"y", 404, 2, Type::i32, Access::write, "nm", ""},
    Register{"z", 406, 2, Type::i32, Access::write, "nm", ""},
    Register{"dir_x", 408, 2, Type::i32, Access::write, "1e-9", "probe: unit approach direction × 10⁹"},
    Register{"dir_y", 410, 2, Type::i32, Access::write, "1e-9", ""},
    Register{"dir_z", 412, 2, Type::i32, Access::write, "1e-9", ""},
    Register{"speed", 414, 2, Type::u32, Access::write, "µm/s", "move, probe: 0 for the machine's default"},
    Register{"max_travel", 416, 2, Type::u32, Access::write, "nm", "probe: search length; set tip: ball radius"},
    Register{"min_travel", 418, 2, Type::u32, Access::write, "nm",
             "probe: a trigger before this is an early trigger; set tip: Unix time of the qualification"},
    Register{"retract", 420, 2, Type::u32, Access::write, "nm", "probe: back-off after the touch; set tip: fit RMS"},
    Register{"probe_flags", 422, 1, Type::u16, Access::write, "bits", "probe: bit 0 fail on a miss"},
    Register{"tip", 423, 1, Type::u16, Access::write, "index", "select tip, set tip: which tip"},
    Register{"touches", 424, 1, Type::u16, Access::write, "", "set tip: touches of the qualification"},
    // Written alone (function 6), accepted at any time, also while a command runs.
    Register{"urgent", 450, 1, Type::u16, Access::write, "", "1 stop (brake, keep position), 2 abort (latched)"},
    Register{"heartbeat", 451, 1, Type::u16, Access::write, "",
             "any new value proves the link alive; when it has not changed for heartbeat_timeout the machine stops"},
    Register{"heartbeat_timeout", 452, 1, Type::u16, Access::write, "ms", "0 (the default) switches the watch off"},
};

// The address of a register by name, at compile time: a misspelt name does not compile.
consteval std::uint16_t address(std::string_view name) {
  for (const auto& r : kRegisters)
    if (r.name == name) return r.address;
  throw "no such register";
}
consteval const Register& entry(std::string_view name) {
  for (const auto& r : kRegisters)
    if (r.name == name) return r;
  throw "no such register";
}

inline constexpr std::uint16_t kStatusFirst = 0, kStatusCount = 25;
inline constexpr std::uint16_t kInfoFirst = 40, kInfoCount = 27;
inline constexpr std::uint16_t kCommandFirst = 400, kCommandCount = 25;
inline constexpr std::uint16_t kRegisterSpace = 460;

// Fault codes on the wire: hal::FaultKind in declaration order from 1 (CommLost 1 … Aborted 10);
// 0 is no fault. An unknown code is a Protocol fault.
std::uint16_t to_code(FaultKind kind);
FaultKind fault_from_code(std::uint16_t code);

// The table as docs/modbus-map.md shows it (a Markdown table, one row per register).
std::string markdown_table();

// Packing values into registers and back, as the table says.
void put_u32(std::uint16_t* regs, std::uint32_t value);
void put_i32(std::uint16_t* regs, std::int32_t value);
std::uint32_t get_u32(const std::uint16_t* regs);
std::int32_t get_i32(const std::uint16_t* regs);
void put_ascii(std::uint16_t* regs, int count, std::string_view text);
std::string get_ascii(const std::uint16_t* regs, int count);
// Millimetres to nanometres, rounded; throws std::out_of_range beyond ±2.147 m.
std::int32_t to_nm(double mm);
std::uint32_t to_unsigned(double value, double unit);  // value / unit, rounded; throws if < 0 or too large

}  // namespace cmm::hal::modbus
