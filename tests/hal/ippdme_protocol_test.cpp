// The I++ DME line grammar both sides share: commands as a server reads them, replies as the
// client reads them, and what each refuses with which code.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hal/ippdme_protocol.hpp"

namespace cmm::hal::ippdme {
namespace {

LineError error_of(std::string_view line) {
  auto parsed = parse_command(line);
  if (auto* e = std::get_if<LineError>(&parsed)) return *e;
  ADD_FAILURE() << "accepted: " << line;
  return {};
}

TEST(IppDmeProtocol, ReadsCommandsWithNestedDottedAndQuotedArguments) {
  auto parsed = parse_command("00042 SetProp(Tool.PtMeasPar.Speed(5.5), Tool.GoToPar.Accel( 100 ))");
  ASSERT_TRUE(std::holds_alternative<Command>(parsed));
  const auto& c = std::get<Command>(parsed);
  EXPECT_EQ(c.tag, (Tag{false, 42}));
  EXPECT_EQ(c.name, "SetProp");
  ASSERT_EQ(c.args.size(), 2u);
  EXPECT_EQ(c.args[0].text, "Tool.PtMeasPar.Speed");
  EXPECT_EQ(number_of(c.args, "Tool.GoToPar.Accel"), 100);
  auto ptmeas = std::get<Command>(parse_command("00003 PtMeas(X(1), Y(-2.5), Z(3e1), IJK(0,0,1))"));
  EXPECT_EQ(vector_of(ptmeas.args, "IJK"), Vec3(0, 0, 1));
  EXPECT_EQ(number_of(ptmeas.args, "Z"), 30);
  auto tool = std::get<Command>(parse_command("E0001 ChangeTool(\"Probe A\")"));
  EXPECT_TRUE(tool.tag.event);
  EXPECT_EQ(tool.args.at(0).kind, Term::Kind::string);
  EXPECT_EQ(tool.args.at(0).text, "Probe A");
  auto csy = std::get<Command>(parse_command("00004 SetCoordSystem(MachineCsy)"));
  EXPECT_EQ(csy.args.at(0).kind, Term::Kind::name);
  // What we print, we read back the same.
  EXPECT_EQ(format_command(ptmeas), "00003 PtMeas(X(1.000000000), Y(-2.500000000), Z(30.000000000), "
                                    "IJK(0.000000000, 0.000000000, 1.000000000))");
  EXPECT_EQ(format_command(std::get<Command>(parse_command(format_command(ptmeas)))), format_command(ptmeas));
}

TEST(IppDmeProtocol, RefusesMalformedCommandsWithTheirCodes) {
  EXPECT_EQ(error_of("0001 Home()").code, kErrorIllegalTag);
  EXPECT_EQ(error_of("00000 Home()").code, kErrorIllegalTag);
  EXPECT_EQ(error_of("X0001 Home()").code, kErrorIllegalTag);
  EXPECT_EQ(error_of("00001Home()").code, kErrorNoSpace);
  EXPECT_EQ(error_of("00001 Home(").code, kErrorProtocol);
  EXPECT_EQ(error_of("00001 Home() x").code, kErrorProtocol);
  EXPECT_EQ(error_of("00001 Home").code, kErrorProtocol);
  EXPECT_EQ(error_of("00001 GoTo(X(1.2.3))").code, kErrorProtocol);
  EXPECT_EQ(error_of("00001 GoTo(X(1e999))").code, kErrorProtocol);
  EXPECT_EQ(error_of("00001 ChangeTool(\"T1)").code, kErrorProtocol);
  EXPECT_EQ(error_of(std::string("00001 Home()\t")).code, kErrorIllegalCharacter);
  EXPECT_EQ(error_of("00001 Home(\xc3\xa9)").code, kErrorIllegalCharacter);
  std::string deep = "00001 Get(";
  for (int i = 0; i < 40; ++i) deep += "X(";
  EXPECT_EQ(error_of(deep).code, kErrorProtocol);
  const LineError long_line = error_of("00007 Get(" + std::string(kMaxLineChars, 'X') + ")");
  EXPECT_EQ(long_line.code, kErrorBufferFull);
  EXPECT_EQ(long_line.tag, (Tag{false, 7}));
  EXPECT_EQ(error_of("00009 Home(").tag, (Tag{false, 9}));
}

TEST(IppDmeProtocol, ReadsEveryKindOfReply) {
  auto ack = parse_reply("00001 &");
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->kind, ReplyKind::ack);
  EXPECT_EQ(parse_reply("00001 %")->kind, ReplyKind::done);
  auto data = parse_reply("00012 # ER(1), X(1.5), IJK(0, 0, 1)");
  ASSERT_TRUE(data);
  EXPECT_EQ(number_of(data->data, "X"), 1.5);
  EXPECT_EQ(vector_of(data->data, "IJK"), Vec3(0, 0, 1));
  auto tools = parse_reply("00003 # \"T1\"");
  ASSERT_TRUE(tools);
  EXPECT_EQ(tools->data.at(0).text, "T1");
  auto error = parse_reply("E0000 ! Error(3, 0500, GoTo, \"Emergency stop\")");
  ASSERT_TRUE(error);
  EXPECT_EQ(error->tag, kServerTag);
  EXPECT_EQ(error->error.severity, 3);
  EXPECT_EQ(error->error.code, 500);
  EXPECT_EQ(error->error.method, "GoTo");
  EXPECT_EQ(error->error.text, "Emergency stop");
  EXPECT_EQ(parse_reply("00001 ! Error(2, 1003, \"\", \"No touch\")")->error.code, 1003);
  EXPECT_EQ(format_reply(*error), "E0000 ! Error(3, 0500, GoTo, \"Emergency stop\")");
  // Found by the fuzzer: a quoted method that is no name is printed quoted, so that it reads back.
  auto quoted = parse_reply("E0000 ! Error(3, 0500, \"0001 OnM\", \"Emergency stop\")");
  ASSERT_TRUE(quoted);
  EXPECT_EQ(format_reply(*quoted), "E0000 ! Error(3, 0500, \"0001 OnM\", \"Emergency stop\")");
  // Found by the fuzzer: a number of 229 digits was cut to the printing buffer's 63.
  auto big = parse_reply("00001 # X(1e228)");
  ASSERT_TRUE(big);
  EXPECT_EQ(number_of(parse_reply(format_reply(*big))->data, "X"), 1e228);
}

TEST(IppDmeProtocol, RefusesMalformedReplies) {
  for (const char* line : {"", "00001", "00001 ", "00001 ?", "00001 & x", "00001 %x", "00001 #", "00001 # X(1",
                           "00001 ! Error(2, 1003)", "00001 ! Error(x, 1003, GoTo, \"t\")", "00001 ! Error(12, 1003, GoTo, \"t\")",
                           "00001 ! Error(2, 10030, GoTo, \"t\")", "00001 ! Error(2.5, 1003, GoTo, \"t\")", "1 &",
                           "00001 ! Failure(2, 1003, GoTo, \"t\")", "00001 # X(1)\x01"})
    EXPECT_FALSE(parse_reply(line)) << line;
}

TEST(IppDmeProtocol, MapsErrorCodesOntoHalFaults) {
  EXPECT_EQ(fault_from_error(kErrorEStop), FaultKind::estop);
  EXPECT_EQ(fault_from_error(kErrorNoTouch), FaultKind::no_contact);
  EXPECT_EQ(fault_from_error(kErrorSurfaceNotFound), FaultKind::no_contact);
  EXPECT_EQ(fault_from_error(kErrorOutOfVolume), FaultKind::soft_limit);
  EXPECT_EQ(fault_from_error(kErrorMachineLimit), FaultKind::hard_limit);
  EXPECT_EQ(fault_from_error(kErrorCollision), FaultKind::early_trigger);
  EXPECT_EQ(fault_from_error(kErrorIllegalCommand), FaultKind::protocol);
  EXPECT_EQ(fault_from_error(kErrorTransactionAborted), FaultKind::aborted);
  EXPECT_EQ(error_text(kErrorBadProperty), "Bad property");
  EXPECT_EQ(default_severity(kErrorNoDaemons), 1);
  EXPECT_EQ(error_text(kErrorToolNotFound), "Tool not found");
  EXPECT_EQ(fault_from_error(kErrorUnsupported), FaultKind::protocol);
  EXPECT_EQ(error_text(kErrorUseClearAllErrors), "Use ClearAllErrors to continue");
  EXPECT_EQ(format_tag({true, 7}), "E0007");
  EXPECT_EQ(format_tag({false, 99999}), "99999");
}

}  // namespace
}  // namespace cmm::hal::ippdme
