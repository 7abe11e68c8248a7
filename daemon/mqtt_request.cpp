// admit_mqtt_request: the requester from the topic, its reply topic, its token.
#include "daemon/mqtt_request.hpp"

namespace cmm::daemon {

MqttAdmission admit_mqtt_request(const MqttMessage& request, const std::string& request_prefix,
                                 const std::string& reply_prefix, TokenBook& tokens) {
  MqttAdmission a;
  if (!request.topic.starts_with(request_prefix)) return a;
  a.user = request.topic.substr(request_prefix.size());
  if (a.user.empty() || a.user.find_first_of("/+#") != std::string::npos) return a;
  const std::string& reply = request.response_topic;
  const std::string replies = reply_prefix + a.user + "/";
  if (reply.size() <= replies.size() || !reply.starts_with(replies) || reply.find_first_of("+#") != std::string::npos)
    return a;
  auto ctx = std::make_shared<RpcContext>(next_connection_id(), "mqtt:" + a.user, Role::none);
  ctx->set_client("mqtt:" + reply);  // a cmmctl's reply topic names that one client, across its requests
  std::string token;
  for (const auto& [name, value] : request.user_properties)
    if (name == "token") token = value;
  if (!token.empty()) {
    try {
      authenticate(tokens, token, *ctx, auth_source(ctx->peer()));  // the user: as server.auth in the payload
    } catch (const RpcError& e) {
      a.kind = MqttAdmission::Kind::refuse;
      a.refusal = error_response(nullptr, e);
      return a;
    }
  }
  a.kind = MqttAdmission::Kind::run;
  a.context = std::move(ctx);
  return a;
}

}  // namespace cmm::daemon
