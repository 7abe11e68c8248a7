// MqttListener: messages under a mutex, waited on with a condition variable.
#include "mqtt_listener.hpp"

#include <chrono>
#include <stdexcept>

#include "daemon/client/station_link.hpp"

namespace cmm::testing {

MqttListener::MqttListener(int port, const std::string& user, const std::string& password,
                           std::vector<std::string> filters)
    : filters_(std::move(filters)) {
  daemon::MqttConnect connect;
  connect.host = "127.0.0.1";
  connect.port = port;
  connect.username = user;
  connect.password = password;
  connect.client_id = daemon::unique_client_id("test-" + user);
  daemon::MqttCallbacks callbacks;
  callbacks.connected = [this] {
    for (const std::string& f : filters_) client_->subscribe(f, 1);
    std::lock_guard lock(mutex_);
    ++connects_;
    arrived_.notify_all();
  };
  callbacks.message = [this](const daemon::MqttMessage& m) {
    std::lock_guard lock(mutex_);
    messages_.push_back(m);
    arrived_.notify_all();
  };
  client_ = std::make_unique<daemon::MqttClient>(connect, std::move(callbacks));
  client_->start();
  std::unique_lock lock(mutex_);
  if (!arrived_.wait_for(lock, std::chrono::seconds(5), [this] { return connects_ > 0; }))
    throw std::runtime_error("MqttListener: no connection to the broker as " + user);
}

MqttListener::~MqttListener() { client_->stop(); }

daemon::MqttMessage MqttListener::wait_for(const std::string& what,
                                           const std::function<bool(const daemon::MqttMessage&)>& match,
                                           double timeout_s) {
  std::unique_lock lock(mutex_);
  std::size_t seen = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                               std::chrono::duration<double>(timeout_s));
  for (;;) {
    for (; seen < messages_.size(); ++seen)
      if (match(messages_[seen])) return messages_[seen];
    if (arrived_.wait_until(lock, deadline) == std::cv_status::timeout && seen == messages_.size())
      throw std::runtime_error("no MQTT message " + what + " within " + std::to_string(timeout_s) + " s");
  }
}

std::vector<daemon::MqttMessage> MqttListener::messages() {
  std::lock_guard lock(mutex_);
  return messages_;
}

}  // namespace cmm::testing
