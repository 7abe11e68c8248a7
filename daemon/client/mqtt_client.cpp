// MqttClient over libmosquitto. The network loop is ours, not mosquitto_loop_start's: that one
// gives up for good on some errors (a host name that does not resolve at boot), and a station's
// link must keep trying for as long as cmmd runs.
#include "daemon/client/mqtt_client.hpp"

#include <mosquitto.h>
#include <mqtt_protocol.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <mutex>
#include <thread>

#include <spdlog/spdlog.h>

namespace cmm::daemon {

namespace {

void init_library() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

// The library's properties list, freed on every path.
struct Properties {
  mosquitto_property* list = nullptr;
  Properties() = default;
  Properties(const Properties&) = delete;
  Properties& operator=(const Properties&) = delete;
  ~Properties() { mosquitto_property_free_all(&list); }
};

std::string error_text(int rc) {
  return rc == MOSQ_ERR_ERRNO ? std::strerror(errno) : mosquitto_strerror(rc);
}

void add_properties(Properties& p, const MqttMessage& m) {
  if (!m.response_topic.empty()) mosquitto_property_add_string(&p.list, MQTT_PROP_RESPONSE_TOPIC, m.response_topic.c_str());
  if (!m.correlation.empty())
    mosquitto_property_add_binary(&p.list, MQTT_PROP_CORRELATION_DATA, m.correlation.data(),
                                  static_cast<std::uint16_t>(std::min<std::size_t>(m.correlation.size(), 65535)));
  for (const auto& [name, value] : m.user_properties)
    mosquitto_property_add_string_pair(&p.list, MQTT_PROP_USER_PROPERTY, name.c_str(), value.c_str());
}

}  // namespace

// libmosquitto's C callbacks; `self` is the MqttClient.
struct MqttCallbacksOf {
  static void connect(mosquitto*, void* self, int rc, int, const mosquitto_property*) {
    auto& c = *static_cast<MqttClient*>(self);
    if (rc != 0) {
      if (c.callbacks_.failed) c.callbacks_.failed(std::string("refused: ") + mosquitto_reason_string(rc));
      return;
    }
    c.connected_ = true;
    if (c.callbacks_.connected) c.callbacks_.connected();
  }

  static void disconnect(mosquitto*, void* self, int rc, const mosquitto_property*) {
    auto& c = *static_cast<MqttClient*>(self);
    const bool was = c.connected_.exchange(false);
    if (was && c.callbacks_.disconnected) c.callbacks_.disconnected(rc == 0 ? "disconnected" : error_text(rc));
  }

  static void message(mosquitto*, void* self, const mosquitto_message* m, const mosquitto_property* props) {
    auto& c = *static_cast<MqttClient*>(self);
    if (!c.callbacks_.message) return;
    MqttMessage message;
    message.topic = m->topic;
    message.payload.assign(static_cast<const char*>(m->payload), static_cast<std::size_t>(std::max(m->payloadlen, 0)));
    message.qos = m->qos;
    message.retain = m->retain;
    char* text = nullptr;
    if (mosquitto_property_read_string(props, MQTT_PROP_RESPONSE_TOPIC, &text, false)) {
      message.response_topic = text;
      std::free(text);
    }
    void* bytes = nullptr;
    std::uint16_t length = 0;
    if (mosquitto_property_read_binary(props, MQTT_PROP_CORRELATION_DATA, &bytes, &length, false)) {
      message.correlation.assign(static_cast<const char*>(bytes), length);
      std::free(bytes);
    }
    bool skip = false;
    for (const mosquitto_property* p = props; p; skip = true) {
      char *name = nullptr, *value = nullptr;
      p = mosquitto_property_read_string_pair(p, MQTT_PROP_USER_PROPERTY, &name, &value, skip);
      if (!p) break;
      message.user_properties.emplace_back(name, value);
      std::free(name);
      std::free(value);
    }
    // An exception must not unwind into libmosquitto's C loop (it would end the process).
    try {
      c.callbacks_.message(message);
    } catch (const std::exception& e) {
      spdlog::error("MQTT {}: a message on {} not handled: {}", c.broker_, message.topic, e.what());
    }
  }

  static void publish(mosquitto*, void* self, int mid, int reason, const mosquitto_property*) {
    auto& c = *static_cast<MqttClient*>(self);
    if (reason < 128 && c.callbacks_.published) c.callbacks_.published(mid);
  }
};

MqttClient::MqttClient(MqttConnect connect, MqttCallbacks callbacks)
    : connect_(std::move(connect)),
      callbacks_(std::move(callbacks)),
      broker_(connect_.host + ":" + std::to_string(connect_.port)) {
  init_library();
  mosq_ = mosquitto_new(connect_.client_id.empty() ? nullptr : connect_.client_id.c_str(), true, this);
  if (!mosq_) throw MqttError("MQTT " + broker_ + ": cannot make a client: " + std::strerror(errno));
  auto check = [this](int rc, const char* doing) {
    if (rc != MOSQ_ERR_SUCCESS) {
      mosquitto_destroy(mosq_);
      throw MqttError("MQTT " + broker_ + ": " + doing + ": " + error_text(rc));
    }
  };
  check(mosquitto_int_option(mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5), "MQTT 5");
  check(mosquitto_threaded_set(mosq_, true), "threads");
  if (!connect_.username.empty())
    check(mosquitto_username_pw_set(mosq_, connect_.username.c_str(),
                                    connect_.password.empty() ? nullptr : connect_.password.c_str()),
          "username");
  if (!connect_.tls.ca_file.empty())
    check(mosquitto_tls_set(mosq_, connect_.tls.ca_file.c_str(), nullptr,
                            connect_.tls.cert_file.empty() ? nullptr : connect_.tls.cert_file.c_str(),
                            connect_.tls.key_file.empty() ? nullptr : connect_.tls.key_file.c_str(), nullptr),
          "TLS files");
  if (connect_.will) {
    Properties props;
    add_properties(props, *connect_.will);
    check(mosquitto_will_set_v5(mosq_, connect_.will->topic.c_str(), static_cast<int>(connect_.will->payload.size()),
                                connect_.will->payload.data(), connect_.will->qos, connect_.will->retain, props.list),
          "last will");
  }
  mosquitto_connect_v5_callback_set(mosq_, &MqttCallbacksOf::connect);
  mosquitto_disconnect_v5_callback_set(mosq_, &MqttCallbacksOf::disconnect);
  mosquitto_message_v5_callback_set(mosq_, &MqttCallbacksOf::message);
  mosquitto_publish_v5_callback_set(mosq_, &MqttCallbacksOf::publish);
}

MqttClient::~MqttClient() {
  stop();
  mosquitto_destroy(mosq_);
}

void MqttClient::start() {
  if (started_) return;
  started_ = true;
  stopping_ = false;
  leaving_ = false;
  // A refusal here (nobody listening yet) is the loop's to retry; only a bad argument is ours.
  const int rc = mosquitto_connect_bind_async(mosq_, connect_.host.c_str(), connect_.port, connect_.keepalive_s, nullptr);
  if (rc == MOSQ_ERR_INVAL) throw MqttError("MQTT " + broker_ + ": invalid host or port");
  if (rc != MOSQ_ERR_SUCCESS && callbacks_.failed) callbacks_.failed(error_text(rc));
  thread_ = std::thread([this] { loop(); });
}

void MqttClient::loop() {
  auto delay = std::chrono::milliseconds(1000);
  while (!stopping_) {
    const int rc = mosquitto_loop(mosq_, 100, 1);
    if (rc == MOSQ_ERR_SUCCESS) {
      if (connected_) delay = std::chrono::milliseconds(1000);
      continue;
    }
    if (stopping_) break;
    if (!connected_ && !leaving_ && callbacks_.failed) callbacks_.failed(error_text(rc));
    // Down: wait (in short steps, so stop() is quick), then try again.
    for (auto waited = std::chrono::milliseconds(0); waited < delay && !stopping_; waited += std::chrono::milliseconds(50))
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    delay = std::min(delay * 2, std::chrono::milliseconds(5000));
    if (!stopping_) mosquitto_reconnect_async(mosq_);
  }
}

void MqttClient::stop() {
  if (!started_) return;
  leaving_ = true;  // the link going down from here on is ours, not a failure to report
  // Reason 4, "disconnect with will message": the broker still publishes the last will, so a
  // station stopped on purpose reads as offline as one that died.
  if (connected_) {
    mosquitto_disconnect_v5(mosq_, MQTT_RC_DISCONNECT_WITH_WILL_MSG, nullptr);
    for (int i = 0; i < 20 && connected_; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
  mosquitto_disconnect(mosq_);
  connected_ = false;
  started_ = false;
}

std::optional<int> MqttClient::publish(const MqttMessage& message) {
  if (!connected_) return std::nullopt;
  Properties props;
  add_properties(props, message);
  int mid = 0;
  const int rc = mosquitto_publish_v5(mosq_, &mid, message.topic.c_str(), static_cast<int>(message.payload.size()),
                                      message.payload.data(), message.qos, message.retain, props.list);
  if (rc == MOSQ_ERR_NO_CONN || rc == MOSQ_ERR_CONN_LOST) return std::nullopt;
  if (rc != MOSQ_ERR_SUCCESS)
    throw MqttError("MQTT " + broker_ + ": cannot publish to " + message.topic + ": " + error_text(rc));
  return mid;
}

void MqttClient::subscribe(const std::string& filter, int qos) {
  const int rc = mosquitto_subscribe_v5(mosq_, nullptr, filter.c_str(), qos, 0, nullptr);
  if (rc != MOSQ_ERR_SUCCESS && rc != MOSQ_ERR_NO_CONN)
    throw MqttError("MQTT " + broker_ + ": cannot subscribe to " + filter + ": " + error_text(rc));
}

bool MqttClient::connected() const { return connected_; }

}  // namespace cmm::daemon
