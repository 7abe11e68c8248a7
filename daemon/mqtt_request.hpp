// A JSON-RPC request that came over MQTT (a station's api/request), without the broker: whether it
// is answered, with which role, and its answer. MqttStation runs these; tests/fuzz feeds them
// anything a broker could carry.
#pragma once

#include <cstdint>
#include <optional>

#include <nlohmann/json.hpp>

#include "daemon/client/json_rpc.hpp"
#include "daemon/client/mqtt_client.hpp"
#include "daemon/token_book.hpp"

namespace cmm::daemon {

struct MqttAdmission {
  enum class Kind {
    // No response topic, or one outside the replies' prefix: an answer on a topic everyone reads
    // would show it to all, and one on the station's own topics would pass for its status or results.
    ignore,
    refuse,  // answered at once with `refusal` (too large, a wrong token)
    run,     // to be answered with `role`
  };
  Kind kind = Kind::ignore;
  nlohmann::json refusal;
  Role role = Role::none;
};

// The token travels as the user property "token"; none is role none (server.info only). Replies go
// only to response topics under `reply_prefix` (<prefix>/clients/, docs/fleet.md) without wildcards.
MqttAdmission admit_mqtt_request(const MqttMessage& request, const std::string& reply_prefix,
                                 std::size_t max_request_bytes, TokenBook& tokens);

// The JSON-RPC response to an admitted request in a context of its own (`context_id`, for logs),
// or nothing for a notification. Never throws for what the payload holds.
std::optional<nlohmann::json> answer_mqtt_request(const MqttMessage& request, Role role, const RpcDispatcher& dispatcher,
                                                  const ParseLimits& limits, std::uint64_t context_id);

}  // namespace cmm::daemon
