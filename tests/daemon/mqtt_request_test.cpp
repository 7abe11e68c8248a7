// A request over MQTT: answered only on its own response topic, with the role its token grants
// (none without one), refused when too large or with a wrong token.
#include "daemon/mqtt_request.hpp"

#include <gtest/gtest.h>

namespace cmm::daemon {
namespace {

using nlohmann::json;

struct Station {
  RpcDispatcher dispatcher;
  TokenBook tokens{{{"observer-token-0123456789", Role::observer}, {"operator-token-0123456789", Role::operator_}}, 10, 10};
  Station() {
    dispatcher.add("server.info", {Role::none, Work::quick, [](const json&, RpcContext& c) {
                     return json{{"role", to_string(c.role())}};
                   }});
    dispatcher.add("job.submit", {Role::operator_, Work::blocking, [](const json&, RpcContext&) { return json{{"id", 1}}; }});
  }
};

MqttMessage request(const std::string& payload, const std::string& token, const std::string& reply = "cmmd/clients/u/c/reply") {
  MqttMessage m;
  m.topic = "cmmd/alpha/api/request";
  m.response_topic = reply;
  m.payload = payload;
  if (!token.empty()) m.user_properties.emplace_back("token", token);
  return m;
}

const std::string kSubmit = R"({"jsonrpc":"2.0","id":7,"method":"job.submit","params":{}})";

TEST(MqttRequest, TheTokensRoleDecidesWhatRuns) {
  Station s;
  const MqttAdmission op = admit_mqtt_request(request(kSubmit, "operator-token-0123456789"), "cmmd/clients/", 1024, s.tokens);
  ASSERT_EQ(op.kind, MqttAdmission::Kind::run);
  EXPECT_EQ(op.role, Role::operator_);
  const auto done = answer_mqtt_request(request(kSubmit, ""), op.role, s.dispatcher, {}, 1);
  ASSERT_TRUE(done);
  EXPECT_EQ((*done)["result"]["id"], 1);
  EXPECT_EQ((*done)["id"], 7);

  const MqttAdmission obs = admit_mqtt_request(request(kSubmit, "observer-token-0123456789"), "cmmd/clients/", 1024, s.tokens);
  ASSERT_EQ(obs.kind, MqttAdmission::Kind::run);
  const auto refused = answer_mqtt_request(request(kSubmit, ""), obs.role, s.dispatcher, {}, 2);
  EXPECT_EQ((*refused)["error"]["code"], rpc_code::unauthorized);

  const MqttAdmission none = admit_mqtt_request(request(kSubmit, ""), "cmmd/clients/", 1024, s.tokens);
  ASSERT_EQ(none.kind, MqttAdmission::Kind::run);
  EXPECT_EQ(none.role, Role::none);
  const auto info = answer_mqtt_request(request(R"({"jsonrpc":"2.0","id":1,"method":"server.info"})", ""), none.role,
                                        s.dispatcher, {}, 3);
  EXPECT_EQ((*info)["result"]["role"], "none");
}

TEST(MqttRequest, AWrongTokenATooLargeRequestAndNoResponseTopicAreNotRun) {
  Station s;
  const MqttAdmission wrong = admit_mqtt_request(request(kSubmit, "not-a-token-of-this-station"), "cmmd/clients/", 1024, s.tokens);
  ASSERT_EQ(wrong.kind, MqttAdmission::Kind::refuse);
  EXPECT_EQ(wrong.refusal["error"]["code"], rpc_code::auth_failed);
  const MqttAdmission large = admit_mqtt_request(request(std::string(2000, ' ') + kSubmit, "operator-token-0123456789"), "cmmd/clients/", 1024, s.tokens);
  ASSERT_EQ(large.kind, MqttAdmission::Kind::refuse);
  EXPECT_EQ(large.refusal["error"]["code"], rpc_code::request_too_large);
  EXPECT_EQ(large.refusal["error"]["data"]["max_request_bytes"], 1024);
  EXPECT_EQ(admit_mqtt_request(request(kSubmit, "operator-token-0123456789", ""), "cmmd/clients/", 1024, s.tokens).kind,
            MqttAdmission::Kind::ignore);
  // A reply would pass for the station's own status or result, or go to many at once.
  for (const char* topic : {"cmmd/alpha/status", "cmmd/alpha/jobs/1/result", "cmmd/clients/", "cmmd/clients/+/x",
                            "cmmd/clients/#", "other/clients/u/c/reply"})
    EXPECT_EQ(admit_mqtt_request(request(kSubmit, "operator-token-0123456789", topic), "cmmd/clients/", 1024, s.tokens).kind,
              MqttAdmission::Kind::ignore)
        << topic;
}

TEST(MqttRequest, WhatIsNoJsonRpcGetsItsErrorAndANotificationNoAnswer) {
  Station s;
  const auto garbage = answer_mqtt_request(request("{\"jsonrpc\":", ""), Role::operator_, s.dispatcher, {}, 1);
  EXPECT_EQ((*garbage)["error"]["code"], rpc_code::parse_error);
  EXPECT_FALSE(answer_mqtt_request(request(R"({"jsonrpc":"2.0","method":"server.info"})", ""), Role::none, s.dispatcher, {}, 2));
}

}  // namespace
}  // namespace cmm::daemon
