// An MQTT 5 client on libmosquitto (the broker's own project, in Debian): its network thread keeps
// the link and reconnects by itself, and every callback runs on that thread. cmmd's station link
// and cmmctl's fleet and --station commands both use it.
#pragma once

#include <atomic>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

struct mosquitto;

namespace cmm::daemon {

// A call the library refused; the message names the broker and what failed.
class MqttError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct MqttTls {
  std::string ca_file;    // the broker's CA (PEM); empty: TLS off
  std::string cert_file;  // a client certificate and its key, when the broker wants one
  std::string key_file;
  bool operator==(const MqttTls&) const = default;
};

struct MqttMessage {
  std::string topic;
  std::string payload;
  int qos = 0;
  bool retain = false;
  std::string response_topic;  // MQTT 5: where the requester wants its reply ("" when none)
  std::string correlation;     // MQTT 5 correlation data, bytes as they came
  std::vector<std::pair<std::string, std::string>> user_properties;
};

struct MqttConnect {
  std::string host = "localhost";
  int port = 1883;
  std::string client_id;  // empty: the library makes one
  std::string username, password;
  MqttTls tls;
  int keepalive_s = 30;
  std::optional<MqttMessage> will;  // published by the broker when the link dies unannounced
};

struct MqttCallbacks {
  std::function<void()> connected;
  std::function<void(const std::string& why)> disconnected;
  std::function<void(const MqttMessage&)> message;
  std::function<void(int message_id)> published;  // QoS 1: the broker acknowledged it
  // An attempt to connect failed (refused, TLS, DNS); the client tries again unless stopped. A
  // one-shot tool gives up here with the reason; a station waits.
  std::function<void(const std::string& why)> failed;
};

class MqttClient {
 public:
  MqttClient(MqttConnect connect, MqttCallbacks callbacks);
  ~MqttClient();
  MqttClient(const MqttClient&) = delete;
  MqttClient& operator=(const MqttClient&) = delete;

  // Starts the network thread and the first connect; a broker that is not there yet is retried
  // (1 s, doubling to 5 s) without end. Throws MqttError for settings the library refuses.
  void start();
  // Sends DISCONNECT (no last will) and joins the thread.
  void stop();

  // Queues a message; returns its id (matched by callbacks.published), or nothing when the link is
  // down (libmosquitto would otherwise keep it in memory only).
  std::optional<int> publish(const MqttMessage& message);
  void subscribe(const std::string& filter, int qos);
  bool connected() const;
  const std::string& broker() const { return broker_; }  // "host:port", for messages

 private:
  friend struct MqttCallbacksOf;  // libmosquitto's C callbacks, in the .cpp

  MqttConnect connect_;
  MqttCallbacks callbacks_;
  std::string broker_;
  mosquitto* mosq_ = nullptr;
  void loop();

  bool started_ = false;
  std::atomic<bool> connected_{false}, stopping_{false}, leaving_{false};
  std::thread thread_;
};

}  // namespace cmm::daemon
