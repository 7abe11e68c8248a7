// The Modbus map is one table: docs/modbus-map.md must show exactly it, and the table must be
// self-consistent (no overlaps, sizes fit types, blocks cover what the driver reads in one go).
#include "hal/modbus_map.hpp"

#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

namespace cmm::hal::modbus {
namespace {

TEST(ModbusMap, TheDocumentShowsTheTable) {
  std::ifstream in(CMMD_SOURCE_DIR "/docs/modbus-map.md");
  ASSERT_TRUE(in) << "docs/modbus-map.md is missing";
  std::stringstream text;
  text << in.rdbuf();
  const std::string doc = text.str();
  const std::string begin = "<!-- register table:", end = "<!-- end of register table -->";
  const auto a = doc.find(begin), b = doc.find(end);
  ASSERT_NE(a, std::string::npos);
  ASSERT_NE(b, std::string::npos);
  const auto table_start = doc.find('\n', a) + 1;
  EXPECT_EQ(doc.substr(table_start, b - table_start), markdown_table())
      << "regenerate the table with: cmm-sim --print-modbus-map";
}

TEST(ModbusMap, RegistersDoNotOverlapAndFitTheirTypes) {
  std::vector<int> owner(kRegisterSpace, -1);
  for (std::size_t i = 0; i < kRegisters.size(); ++i) {
    const Register& r = kRegisters[i];
    const int expected = r.type == Type::u16 ? 1 : r.type == Type::ascii ? r.count : 2;
    EXPECT_EQ(r.count, expected) << r.name;
    ASSERT_LE(r.address + r.count, kRegisterSpace) << r.name;
    for (int k = r.address; k < r.address + r.count; ++k) {
      EXPECT_EQ(owner[static_cast<std::size_t>(k)], -1) << r.name << " overlaps at " << k;
      owner[static_cast<std::size_t>(k)] = static_cast<int>(i);
    }
    const bool in_command = r.address >= kCommandFirst && r.address < kCommandFirst + kCommandCount;
    EXPECT_EQ(r.access == Access::write, in_command || r.address >= address("urgent")) << r.name;
    if (r.access == Access::write && in_command) {
      EXPECT_LE(r.address + r.count, kCommandFirst + kCommandCount) << r.name;
    }
  }
  // What the driver reads in one request lies inside its block; a tip entry fits its stride, and
  // all eight entries fit below the fault text.
  EXPECT_LE(address("touch_clock") + 2, kStatusFirst + kStatusCount);
  EXPECT_LE(address("tip_count") + 1, kInfoFirst + kInfoCount);
  EXPECT_LE(address("tip_touches") + 1 - address("tip_id"), kTipStride);
  EXPECT_LE(address("tip_id") + kMaxTips * kTipStride, address("fault_text"));
  EXPECT_LE(kStatusCount, 125);  // one function-3 request reads at most 125 registers
  EXPECT_LE(kCommandCount, 123);  // one function-16 request writes at most 123
}

TEST(ModbusMap, PackingRoundTrips) {
  std::uint16_t regs[8] = {};
  put_i32(regs, -123456789);
  EXPECT_EQ(regs[0], 0xF8A4);  // high word first
  EXPECT_EQ(get_i32(regs), -123456789);
  put_u32(regs, 4000000000u);
  EXPECT_EQ(get_u32(regs), 4000000000u);
  put_ascii(regs, 4, "T12");
  EXPECT_EQ(regs[0], ('T' << 8) | '1');
  EXPECT_EQ(get_ascii(regs, 4), "T12");
  EXPECT_EQ(to_nm(1.0000004), 1000000);
  EXPECT_EQ(to_nm(-250.5), -250500000);
  EXPECT_THROW(to_nm(2200), std::out_of_range);
  EXPECT_THROW(to_unsigned(-1, 1e-6), std::out_of_range);
  for (auto kind : {FaultKind::comm_lost, FaultKind::no_contact, FaultKind::aborted})
    EXPECT_EQ(fault_from_code(to_code(kind)), kind);
  EXPECT_EQ(to_code(FaultKind::comm_lost), 1);
  EXPECT_EQ(to_code(FaultKind::aborted), 10);
  EXPECT_THROW(fault_from_code(0), Protocol);
  EXPECT_THROW(fault_from_code(11), Protocol);
}

}  // namespace
}  // namespace cmm::hal::modbus
