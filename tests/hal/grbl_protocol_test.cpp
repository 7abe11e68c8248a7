// The Grbl 1.1 dialect's lines: status reports, probe reports, error/alarm codes and their faults.
#include <gtest/gtest.h>

#include "hal/grbl_protocol.hpp"

namespace cmm::hal::grbl {
namespace {

TEST(GrblStatus, ParsesRealGrblAndOurExtension) {
  auto r = parse_status("<Idle|MPos:1.000,-2.500,3.250|FS:0,0|WCO:0.000,0.000,0.000>");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->state, "Idle");
  EXPECT_EQ(r->substate, -1);
  EXPECT_DOUBLE_EQ(r->mpos.y(), -2.5);
  EXPECT_FALSE(r->clock_s);
  r = parse_status("<Hold:0|MPos:0.000001,2,3|FS:600,0|Pn:PR|T:6.000000>");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->state, "Hold");
  EXPECT_EQ(r->substate, 0);
  EXPECT_DOUBLE_EQ(r->mpos.x(), 1e-6);
  EXPECT_EQ(r->pins, "PR");
  EXPECT_DOUBLE_EQ(*r->clock_s, 6);
  EXPECT_FALSE(parse_status("<Idle|WPos:1,2,3|FS:0,0>"));  // our driver needs MPos
  EXPECT_FALSE(parse_status("<Idle|MPos:1,2|FS:0,0>"));
  EXPECT_FALSE(parse_status("Idle|MPos:1,2,3"));
}

// Found by the grbl fuzz target (tests/fuzz/corpus/grbl/crash-f6571d5e…): a substate beyond int was
// cast from double (undefined behaviour), and nan or inf passed as a position.
TEST(GrblStatus, RefusesASubstateBeyondIntAndNumbersThatAreNotFinite) {
  EXPECT_FALSE(parse_status("<Hold:1e307|MPos:0,0,0|FS:0,0>"));
  EXPECT_FALSE(parse_status("<Hold:-1|MPos:0,0,0|FS:0,0>"));
  EXPECT_FALSE(parse_status("<Hold:0.5|MPos:0,0,0|FS:0,0>"));
  EXPECT_EQ(parse_status("<Door:1|MPos:0,0,0|FS:0,0>")->substate, 1);
  EXPECT_FALSE(parse_status("<Idle|MPos:nan,0,0|FS:0,0>"));
  EXPECT_FALSE(parse_status("<Idle|MPos:0,inf,0|FS:0,0>"));
  EXPECT_FALSE(parse_status("<Idle|MPos:0,0,0|FS:-inf,0>"));
  EXPECT_FALSE(parse_status("<Idle|MPos:0,0,0|T:nan>"));
  EXPECT_FALSE(parse_probe("[PRB:1e999,0,0:1]"));
}

TEST(GrblStatus, RoundTripsToANanometre) {
  StatusReport r;
  r.state = "Run";
  r.mpos = Vec3(250.1234564, -0.0000004, 47);
  r.feed_mm_min = 12000;
  r.clock_s = 1.5;
  const std::string line = format_status(r);
  EXPECT_EQ(line, "<Run|MPos:250.123456,0.000000,47.000000|FS:12000.000000,0|T:1.500000>");
  auto back = parse_status(line);
  ASSERT_TRUE(back);
  EXPECT_LT((back->mpos - r.mpos).norm(), 1e-6);
}

TEST(GrblProbe, ParsesAndPrints) {
  auto p = parse_probe("[PRB:1.5,2,-3.000001:1]");
  ASSERT_TRUE(p);
  EXPECT_TRUE(p->success);
  EXPECT_DOUBLE_EQ(p->position.z(), -3.000001);
  EXPECT_FALSE(parse_probe("[PRB:1,2,3:2]"));
  EXPECT_FALSE(parse_probe("[PRB:1,2:1]"));
  EXPECT_EQ(format_probe({Vec3(1, 2, 3), false}), "[PRB:1.000000,2.000000,3.000000:0]");
}

TEST(GrblCodes, MapToTypedFaults) {
  EXPECT_EQ(parse_error("error:9"), 9);
  EXPECT_EQ(parse_alarm("ALARM:5"), 5);
  EXPECT_FALSE(parse_error("error:"));
  EXPECT_FALSE(parse_alarm("ALARM:5x"));
  EXPECT_FALSE(parse_error("ok"));
  EXPECT_EQ(fault_from_error(9), FaultKind::not_homed);
  EXPECT_EQ(fault_from_error(15), FaultKind::soft_limit);
  EXPECT_EQ(fault_from_error(20), FaultKind::protocol);
  EXPECT_EQ(fault_from_alarm(1), FaultKind::hard_limit);
  EXPECT_EQ(fault_from_alarm(2), FaultKind::soft_limit);
  EXPECT_EQ(fault_from_alarm(3), FaultKind::aborted);
  EXPECT_EQ(fault_from_alarm(4), FaultKind::early_trigger);
  EXPECT_EQ(fault_from_alarm(5), FaultKind::no_contact);
}

}  // namespace
}  // namespace cmm::hal::grbl
