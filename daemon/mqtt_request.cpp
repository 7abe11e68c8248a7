// admit_mqtt_request and answer_mqtt_request: the transport's rules of RpcSession, for one message.
#include "daemon/mqtt_request.hpp"

namespace cmm::daemon {

MqttAdmission admit_mqtt_request(const MqttMessage& request, const std::string& reply_prefix,
                                 std::size_t max_request_bytes, TokenBook& tokens) {
  MqttAdmission a;
  const std::string& reply = request.response_topic;
  if (reply.size() <= reply_prefix.size() || !reply.starts_with(reply_prefix) ||
      reply.find_first_of("+#") != std::string::npos)
    return a;
  a.kind = MqttAdmission::Kind::refuse;
  if (request.payload.size() > max_request_bytes) {
    a.refusal = error_response(nullptr, RpcError(rpc_code::request_too_large,
                                                 "request of " + std::to_string(request.payload.size()) +
                                                     " bytes is over the limit",
                                                 {{"max_request_bytes", max_request_bytes}}));
    return a;
  }
  std::string token;
  for (const auto& [name, value] : request.user_properties)
    if (name == "token") token = value;
  if (!token.empty()) {
    const TokenCheck check = tokens.check(token);
    if (check.throttled) {
      a.refusal = error_response(nullptr, RpcError(rpc_code::auth_failed, "too many failed tokens: try again later",
                                                   {{"retry_after_s", check.retry_after_s}}));
      return a;
    }
    if (!check.role) {
      a.refusal = error_response(nullptr, RpcError(rpc_code::auth_failed, "unknown token"));
      return a;
    }
    a.role = *check.role;
  }
  a.kind = MqttAdmission::Kind::run;
  return a;
}

std::optional<nlohmann::json> answer_mqtt_request(const MqttMessage& request, Role role, const RpcDispatcher& dispatcher,
                                                  const ParseLimits& limits, std::uint64_t context_id) {
  RpcContext ctx(context_id, "mqtt:" + request.response_topic, role);
  try {
    return dispatcher.handle(parse_message(request.payload, limits), ctx);
  } catch (const RpcError& e) {
    return error_response(nullptr, e);
  }
}

}  // namespace cmm::daemon
