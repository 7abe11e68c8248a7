// An MQTT client for the fleet tests that keeps every message it gets on its subscriptions.
#pragma once

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "daemon/client/mqtt_client.hpp"

namespace cmm::testing {

class MqttListener {
 public:
  // Connects as user/password to 127.0.0.1:port and subscribes to each filter (QoS 1) on every
  // connect; waits up to 5 s for the first one.
  MqttListener(int port, const std::string& user, const std::string& password, std::vector<std::string> filters);
  ~MqttListener();

  // The first message so far or within timeout_s that `match` accepts; throws std::runtime_error
  // naming `what` otherwise.
  daemon::MqttMessage wait_for(const std::string& what, const std::function<bool(const daemon::MqttMessage&)>& match,
                               double timeout_s);
  std::vector<daemon::MqttMessage> messages();  // a copy of all so far
  daemon::MqttClient& client() { return *client_; }

 private:
  std::vector<std::string> filters_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::vector<daemon::MqttMessage> messages_;
  int connects_ = 0;
  std::unique_ptr<daemon::MqttClient> client_;
};

}  // namespace cmm::testing
