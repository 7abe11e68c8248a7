// `cmmctl fleet`: every station a broker holds a status for (the retained <prefix>/+/status
// messages, docs/fleet.md), online or not.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/client/mqtt_client.hpp"

namespace cmm::daemon {

// A station's status as the listing shows it: the payload with "station" from the topic
// (<prefix>/<station>/status); nothing for another topic or a payload that is not a JSON object.
std::optional<nlohmann::json> fleet_entry(const std::string& topic, const std::string& topic_prefix,
                                          const std::string& payload);

// One line of `cmmctl fleet`: "alpha            online   machine up (enabled)  job 3 probing";
// members of the wrong type read as text, so no payload can stop the listing.
std::string fleet_line(const nlohmann::json& status);

// The stations' status payloads, sorted by station. Retained messages come right after the
// subscription; the listing ends once none came for `quiet_s` (or after `max_s`). Throws
// std::runtime_error naming why when the first attempt to connect fails (refused, TLS, a wrong
// password) or no broker answers within `connect_timeout_s`.
std::vector<nlohmann::json> list_fleet(MqttConnect broker, const std::string& topic_prefix, double connect_timeout_s = 5,
                                       double quiet_s = 0.3, double max_s = 5);

}  // namespace cmm::daemon
