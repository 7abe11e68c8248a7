// Who asks, over MQTT, and whether the station answers: the broker's ACL lets a user publish a
// station's requests only on <prefix>/<station>/api/request/<user> (Mosquitto's %u), so the topic
// names the requester; its answer goes only under <prefix>/clients/<user>/. Without the broker, so
// that tests and the fuzzer feed it anything a broker could carry; RequestGate does the rest.
#pragma once

#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/client/json_rpc.hpp"
#include "daemon/client/mqtt_client.hpp"
#include "daemon/token_book.hpp"

namespace cmm::daemon {

struct MqttAdmission {
  enum class Kind {
    // Not a request topic of a user, or a response topic outside that user's replies: an answer on
    // a topic others read would show it to them, and one on the station's own topics would pass
    // for its status or results.
    ignore,
    refuse,  // answered at once with `refusal` (a wrong token)
    run,     // to be answered, in `context` (the user, the role its token grants: none without one)
  };
  Kind kind = Kind::ignore;
  std::string user;
  nlohmann::json refusal;
  std::shared_ptr<RpcContext> context;
};

// `request_prefix`: <prefix>/<station>/api/request/; `reply_prefix`: <prefix>/clients/. The token
// travels as the user property "token"; a wrong one counts against the user alone.
MqttAdmission admit_mqtt_request(const MqttMessage& request, const std::string& request_prefix,
                                 const std::string& reply_prefix, TokenBook& tokens);

}  // namespace cmm::daemon
