// The request gate every transport shares: the line protocol's JSON-only rules (HTTP closes at any
// time, anything but a JSON object or array closes before authentication), size, pending and
// worker limits, quick methods answered at once and slow ones handed on.
#include "daemon/request_gate.hpp"

#include <gtest/gtest.h>

namespace cmm::daemon {
namespace {

using nlohmann::json;
using Kind = GateDecision::Kind;

struct Gate {
  RpcDispatcher dispatcher;
  RequestGate lines{dispatcher, {.max_request_bytes = 256, .max_batch_entries = 4, .max_pending_requests = 2}, Framing::lines};
  RequestGate messages{dispatcher, {.max_request_bytes = 256, .max_batch_entries = 4, .max_pending_requests = 2},
                       Framing::messages};
  Gate() {
    dispatcher.add("server.info", {Role::none, Work::quick, [](const json&, RpcContext&) { return json{{"name", "cmmd"}}; }});
    dispatcher.add("machine.jog", {Role::operator_, Work::blocking, [](const json&, RpcContext&) { return json{{"jog", 1}}; }});
  }
};

const AdmitWork kTaken = [](Work, std::size_t, std::size_t) { return std::optional<std::string>(); };
const std::string kJog = R"({"jsonrpc":"2.0","id":1,"method":"machine.jog","params":{"direction":[1,0,0]}})";

TEST(LooksLikeHttp, RequestLinesAndHeadersButNoJson) {
  for (const char* line : {"POST / HTTP/1.1", "GET /rpc HTTP/1.1", "OPTIONS * HTTP/1.1", "PRI * HTTP/2.0",
                           "Host: 127.0.0.1:7620", "Origin: http://evil.example", "content-type: text/plain",
                           "  Sec-Fetch-Mode: no-cors", "CONNECT 127.0.0.1:7620 HTTP/1.1"})
    EXPECT_TRUE(looks_like_http(line)) << line;
  for (const char* line : {R"({"jsonrpc":"2.0"})", "[1,2]", "", "   ", "null", "true", "42", "\"POST / HTTP/1.1\"",
                           "{\"Host\": 1}"})
    EXPECT_FALSE(looks_like_http(line)) << line;
}

TEST(RequestGate, TheLineProtocolClosesOnHttpAtAnyTimeAndOnAnythingButJsonBeforeAuthentication) {
  Gate g;
  RpcContext tcp(1, "tcp://127.0.0.1:1", Role::none);
  EXPECT_EQ(g.lines.admit("POST / HTTP/1.1", tcp, 0, kTaken).kind, Kind::close);
  EXPECT_EQ(g.lines.admit("Origin: http://evil.example", tcp, 0, kTaken).kind, Kind::close);
  EXPECT_EQ(g.lines.admit("hello", tcp, 0, kTaken).kind, Kind::close);
  EXPECT_EQ(g.lines.admit("42", tcp, 0, kTaken).kind, Kind::close);
  EXPECT_EQ(g.lines.admit("{\"jsonrpc\":", tcp, 0, kTaken).kind, Kind::answer) << "JSON-looking, broken: −32700";
  const GateDecision info = g.lines.admit(R"({"jsonrpc":"2.0","id":1,"method":"server.info"})", tcp, 0, kTaken);
  ASSERT_EQ(info.kind, Kind::answer);
  EXPECT_EQ((*info.answer)["result"]["name"], "cmmd");
  const GateDecision jog = g.lines.admit(kJog, tcp, 0, kTaken);
  ASSERT_EQ(jog.kind, Kind::answer) << "role none: refused, not run";
  EXPECT_EQ((*jog.answer)["error"]["code"], rpc_code::unauthorized);

  tcp.set_role(Role::operator_);
  tcp.mark_authenticated();
  const GateDecision garbage = g.lines.admit("hello", tcp, 0, kTaken);
  ASSERT_EQ(garbage.kind, Kind::answer) << "after authentication, today's −32700 rule";
  EXPECT_EQ((*garbage.answer)["error"]["code"], rpc_code::parse_error);
  EXPECT_EQ(g.lines.admit("POST / HTTP/1.1", tcp, 0, kTaken).kind, Kind::close) << "HTTP closes whatever the role";
  EXPECT_EQ(g.lines.admit(kJog, tcp, 0, kTaken).kind, Kind::run);

  // A WebSocket or MQTT message has no such rule: its framing is not reachable by a form post.
  RpcContext ws(2, "ws://127.0.0.1:2", Role::observer);
  EXPECT_EQ((*g.messages.admit("hello", ws, 0, kTaken).answer)["error"]["code"], rpc_code::parse_error);
}

TEST(RequestGate, SizePendingAndWorkerLimitsAreDecidedHere) {
  Gate g;
  RpcContext op(1, "unix:/x", Role::operator_, true);
  const GateDecision big = g.messages.admit(std::string(300, ' ') + kJog, op, 0, kTaken);
  ASSERT_EQ(big.kind, Kind::close);
  EXPECT_EQ((*big.answer)["error"]["code"], rpc_code::request_too_large);
  const GateDecision pending = g.messages.admit(kJog, op, 2, kTaken);
  ASSERT_EQ(pending.kind, Kind::answer);
  EXPECT_EQ((*pending.answer)["error"]["code"], rpc_code::too_many_pending);
  const GateDecision busy = g.messages.admit(kJog, op, 0, [](Work, std::size_t, std::size_t) {
    return std::optional<std::string>("all workers busy");
  });
  ASSERT_EQ(busy.kind, Kind::answer);
  EXPECT_EQ((*busy.answer)["error"]["code"], rpc_code::server_busy);
  const GateDecision run = g.messages.admit(kJog, op, 0, kTaken);
  ASSERT_EQ(run.kind, Kind::run);
  EXPECT_EQ(run.work, Work::blocking);
  EXPECT_EQ(run.count, 1u);
  EXPECT_EQ(json::parse(*g.messages.run(run.message, op))["result"]["jog"], 1);
  EXPECT_EQ(g.messages.admit("  ", op, 0, kTaken).kind, Kind::nothing);
  EXPECT_EQ(g.messages.admit(R"({"jsonrpc":"2.0","method":"server.info"})", op, 0, kTaken).kind, Kind::nothing);
  EXPECT_EQ((*g.messages.admit("[1,2,3,4,5]", op, 0, kTaken).answer)["error"]["code"], rpc_code::batch_too_large);
}

}  // namespace
}  // namespace cmm::daemon
