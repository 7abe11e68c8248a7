// The Modbus status decode on register values alone: the map's packing, the active tip by index, and
// a short block or an unknown fault code refused as a Protocol fault rather than read past its end.
#include <gtest/gtest.h>

#include <vector>

#include "hal/fault.hpp"
#include "hal/modbus_map.hpp"
#include "hal/modbus_status.hpp"

namespace cmm::hal::modbus {
namespace {

std::vector<std::uint16_t> status_block() {
  std::vector<std::uint16_t> r(kStatusCount, 0);
  r[address("flags")] = homed | estop;
  put_i32(&r[address("position_x")], 1'500'000);
  put_i32(&r[address("position_y")], -2'000'000);
  put_i32(&r[address("position_z")], 60'000'000);
  put_u32(&r[address("clock")], 12'345);
  r[address("active_tip")] = 1;
  put_i32(&r[address("touch_x")], 100'000'000);
  put_u32(&r[address("touch_travel")], 4'250'000);
  put_u32(&r[address("touch_clock")], 13'000);
  return r;
}

TEST(ModbusStatus, DecodesTheStatusBlock) {
  const MachineStatus s = decode_status(status_block(), {"T1", "T2"});
  EXPECT_TRUE(s.homed);
  EXPECT_TRUE(s.estop);
  EXPECT_FALSE(s.moving);
  EXPECT_FALSE(s.fault);
  EXPECT_DOUBLE_EQ(s.position.x(), 1.5);
  EXPECT_DOUBLE_EQ(s.position.y(), -2);
  EXPECT_DOUBLE_EQ(s.t_s, 12.345);
  EXPECT_EQ(s.tip_id, "T2");
  EXPECT_EQ(decode_status(status_block(), {"T1"}).tip_id, "");  // an index past the table names no tip
}

TEST(ModbusStatus, ATouchWithoutContactEndsWhereTheSearchEnded) {
  auto r = status_block();
  TouchResult t = decode_touch(r, {"T1", "T2"});
  EXPECT_FALSE(t.contact);
  EXPECT_DOUBLE_EQ(t.centre.x(), 1.5);  // the position, not touch_x
  EXPECT_DOUBLE_EQ(t.travel_mm, 4.25);
  EXPECT_DOUBLE_EQ(t.t_s, 13);
  EXPECT_EQ(t.tip_id, "T2");
  r[address("touch_contact")] = 1;
  t = decode_touch(r, {"T1", "T2"});
  EXPECT_TRUE(t.contact);
  EXPECT_DOUBLE_EQ(t.centre.x(), 100);
}

TEST(ModbusStatus, AShortBlockOrAnUnknownFaultIsAProtocolFault) {
  auto r = status_block();
  r.pop_back();
  EXPECT_THROW(decode_status(r, {}), Protocol);
  EXPECT_THROW(decode_touch(r, {}), Protocol);
  EXPECT_THROW(decode_tip(std::vector<std::uint16_t>(kTipEntryCount - 1, 0)), Protocol);
  r = status_block();
  r[address("fault_code")] = 99;
  EXPECT_THROW(decode_status(r, {}), Protocol);
  r[address("fault_code")] = to_code(FaultKind::soft_limit);
  EXPECT_EQ(decode_status(r, {}).fault, FaultKind::soft_limit);
}

TEST(ModbusStatus, DecodesATipEntry) {
  std::vector<std::uint16_t> e(kTipEntryCount, 0);
  const auto at = [&](std::uint16_t register_address) { return &e[register_address - address("tip_id")]; };
  put_ascii(at(address("tip_id")), 4, "T2");
  put_u32(at(address("tip_radius")), 2'499'000);
  put_i32(at(address("tip_offset_z")), -3'000);
  description::StylusTip tip = decode_tip(e);
  EXPECT_EQ(tip.id, "T2");
  EXPECT_DOUBLE_EQ(tip.ball_radius_mm, 2.499);
  EXPECT_DOUBLE_EQ(tip.offset.z(), -0.003);
  EXPECT_FALSE(tip.qualification);
  put_u32(at(address("tip_qualified")), 1'764'000'000);
  *at(address("tip_touches")) = 25;
  tip = decode_tip(e);
  ASSERT_TRUE(tip.qualification);
  EXPECT_EQ(tip.qualification->touches, 25);
  EXPECT_EQ(tip.qualification->time_utc, "2025-11-24T16:00:00Z");
}

}  // namespace
}  // namespace cmm::hal::modbus
