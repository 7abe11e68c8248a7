// cmmd.json's "mqtt" block: the station's link to a fleet's broker (docs/fleet.md). Off by default.
#pragma once

#include <string>

#include "daemon/client/mqtt_client.hpp"

namespace cmm::daemon {

struct MqttOptions {
  bool enabled = false;
  std::string broker = "localhost";
  int port = 1883;
  std::string username, password;
  MqttTls tls;                        // tls.ca_file set: TLS on
  std::string station;                // "" : cmmd.json's top-level station (the host's name)
  std::string topic_prefix = "cmmd";  // topics are <prefix>/<station>/...
  int keepalive_s = 30;
  double progress_interval_s = 1;     // jobs/<id>/progress at most this often per job
  bool operator==(const MqttOptions&) const = default;
};

}  // namespace cmm::daemon
