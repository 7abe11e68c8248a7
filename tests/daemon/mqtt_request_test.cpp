// A request over MQTT: the requester is the broker user its topic names, answered only on a response
// topic under that user's replies, with the role its token grants (none without one); a wrong token
// counts against that user alone; the request gate then does what it does for every transport.
#include "daemon/mqtt_request.hpp"

#include <gtest/gtest.h>

#include "daemon/request_gate.hpp"

namespace cmm::daemon {
namespace {

using nlohmann::json;

const std::string kOperatorToken = "operator-token-0123456789", kObserverToken = "observer-token-0123456789";
const std::string kRequests = "cmmd/alpha/api/request/", kReplies = "cmmd/clients/";

struct Station {
  RpcDispatcher dispatcher;
  TokenBook tokens{{{kObserverToken, Role::observer}, {kOperatorToken, Role::operator_}}, 10, 10};
  RequestGate gate{dispatcher, {.max_request_bytes = 1024, .max_batch_entries = 128, .max_pending_requests = 16},
                   Framing::messages};
  Station() {
    dispatcher.add("server.info", {Role::none, Work::quick, [](const json&, RpcContext& c) {
                     return json{{"role", to_string(c.role())}};
                   }});
    dispatcher.add("machine.stop", {Role::observer, Work::quick, [](const json&, RpcContext&) { return json::object(); }});
    dispatcher.add("job.submit", {Role::operator_, Work::blocking, [](const json&, RpcContext&) { return json{{"id", 1}}; }});
  }
  MqttAdmission admit(const MqttMessage& m) { return admit_mqtt_request(m, kRequests, kReplies, tokens); }
  // What the station answers: at once (quick), or after running on its threads (slow).
  std::optional<json> answer(const MqttMessage& m, RpcContext& ctx) {
    const GateDecision d = gate.admit(m.payload, ctx, 0, [](Work, std::size_t, std::size_t) { return std::optional<std::string>(); });
    if (d.kind == GateDecision::Kind::run) {
      const auto text = gate.run(d.message, ctx);
      return text ? std::optional<json>(json::parse(*text)) : std::nullopt;
    }
    return d.answer;
  }
};

MqttMessage request(const std::string& payload, const std::string& token, const std::string& user = "ops",
                    const std::string& reply = "cmmd/clients/ops/c/reply") {
  MqttMessage m;
  m.topic = kRequests + user;
  m.response_topic = reply;
  m.payload = payload;
  if (!token.empty()) m.user_properties.emplace_back("token", token);
  return m;
}

const std::string kSubmit = R"({"jsonrpc":"2.0","id":7,"method":"job.submit","params":{}})";
const std::string kStop = R"({"jsonrpc":"2.0","id":8,"method":"machine.stop"})";

TEST(MqttRequest, TheTokensRoleDecidesWhatRuns) {
  Station s;
  const MqttAdmission op = s.admit(request(kSubmit, kOperatorToken));
  ASSERT_EQ(op.kind, MqttAdmission::Kind::run);
  EXPECT_EQ(op.user, "ops");
  EXPECT_EQ(op.context->role(), Role::operator_);
  EXPECT_EQ(op.context->client(), "mqtt:cmmd/clients/ops/c/reply");
  const auto done = s.answer(request(kSubmit, ""), *op.context);
  ASSERT_TRUE(done);
  EXPECT_EQ((*done)["result"]["id"], 1);
  EXPECT_EQ((*done)["id"], 7);

  const MqttAdmission obs = s.admit(request(kSubmit, kObserverToken));
  ASSERT_EQ(obs.kind, MqttAdmission::Kind::run);
  EXPECT_EQ((*s.answer(request(kSubmit, ""), *obs.context))["error"]["code"], rpc_code::unauthorized);
  EXPECT_TRUE((*s.answer(request(kStop, ""), *obs.context)).contains("result")) << "an observer may stop";

  const MqttAdmission none = s.admit(request(kSubmit, ""));
  ASSERT_EQ(none.kind, MqttAdmission::Kind::run);
  EXPECT_EQ(none.context->role(), Role::none);
  EXPECT_EQ((*s.answer(request(R"({"jsonrpc":"2.0","id":1,"method":"server.info"})", ""), *none.context))["result"]["role"],
            "none");
  EXPECT_EQ((*s.answer(request(kStop, ""), *none.context))["error"]["code"], rpc_code::unauthorized);
}

TEST(MqttRequest, AWrongTokenATooLargeRequestAndAnotherUsersRepliesAreNotRun) {
  Station s;
  const MqttAdmission wrong = s.admit(request(kSubmit, "not-a-token-of-this-station"));
  ASSERT_EQ(wrong.kind, MqttAdmission::Kind::refuse);
  EXPECT_EQ(wrong.refusal["error"]["code"], rpc_code::auth_failed);
  const MqttAdmission large = s.admit(request(std::string(2000, ' ') + kSubmit, kOperatorToken));
  ASSERT_EQ(large.kind, MqttAdmission::Kind::run);
  const auto too_large = s.answer(request(std::string(2000, ' ') + kSubmit, ""), *large.context);
  EXPECT_EQ((*too_large)["error"]["code"], rpc_code::request_too_large);
  EXPECT_EQ((*too_large)["error"]["data"]["max_request_bytes"], 1024);
  EXPECT_EQ(s.admit(request(kSubmit, kOperatorToken, "ops", "")).kind, MqttAdmission::Kind::ignore);
  // A reply would pass for the station's own status or result, go to many at once, or to another user.
  for (const char* topic : {"cmmd/alpha/status", "cmmd/alpha/jobs/1/result", "cmmd/clients/", "cmmd/clients/ops/",
                            "cmmd/clients/+/x", "cmmd/clients/#", "cmmd/clients/ops/+", "cmmd/clients/viewer/c/reply",
                            "other/clients/ops/c/reply"})
    EXPECT_EQ(s.admit(request(kSubmit, kOperatorToken, "ops", topic)).kind, MqttAdmission::Kind::ignore) << topic;
  // Only api/request/<user>: the old shared topic, a deeper one or a wildcard names nobody.
  for (const char* user : {"", "ops/deeper", "+", "#"})
    EXPECT_EQ(s.admit(request(kSubmit, kOperatorToken, user)).kind, MqttAdmission::Kind::ignore) << user;
  MqttMessage shared = request(kSubmit, kOperatorToken);
  shared.topic = "cmmd/alpha/api/request";
  EXPECT_EQ(s.admit(shared).kind, MqttAdmission::Kind::ignore);
}

// A broker user flooding wrong tokens is throttled alone: the operator's user, and the flooder's
// own right token, are never refused.
TEST(MqttRequest, WrongTokensCountAgainstTheirUserAloneAndARightTokenAlwaysPasses) {
  Station s;
  int throttled = 0;
  for (int i = 0; i < 200; ++i) {
    const MqttAdmission a = s.admit(request(kStop, "wrong-token-" + std::to_string(i), "mallory", "cmmd/clients/mallory/m/reply"));
    ASSERT_EQ(a.kind, MqttAdmission::Kind::refuse);
    if (a.refusal["error"].contains("data") && a.refusal["error"]["data"].contains("retry_after_s")) ++throttled;
    if (i % 10 == 0) {
      const MqttAdmission op = s.admit(request(kStop, kOperatorToken));
      ASSERT_EQ(op.kind, MqttAdmission::Kind::run) << "the operator's token failed during the flood, at guess " << i;
      EXPECT_EQ(op.context->role(), Role::operator_);
    }
  }
  EXPECT_GT(throttled, 150) << "the flooding user is throttled";
  const MqttAdmission own = s.admit(request(kStop, kObserverToken, "mallory", "cmmd/clients/mallory/m/reply"));
  ASSERT_EQ(own.kind, MqttAdmission::Kind::run) << "a right token is compared first, even from a throttled user";
  EXPECT_EQ(own.context->role(), Role::observer);
}

TEST(MqttRequest, WhatIsNoJsonRpcGetsItsErrorAndANotificationNoAnswer) {
  Station s;
  const MqttAdmission a = s.admit(request("{\"jsonrpc\":", kOperatorToken));
  ASSERT_EQ(a.kind, MqttAdmission::Kind::run);
  EXPECT_EQ((*s.answer(request("{\"jsonrpc\":", ""), *a.context))["error"]["code"], rpc_code::parse_error);
  EXPECT_FALSE(s.answer(request(R"({"jsonrpc":"2.0","method":"server.info"})", ""), *a.context));
}

}  // namespace
}  // namespace cmm::daemon
