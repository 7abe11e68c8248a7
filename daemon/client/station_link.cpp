// StationLink: one MQTT client, subscribed to its reply topic and the station's job topics.
#include "daemon/client/station_link.hpp"

#include <unistd.h>

#include <algorithm>
#include <random>

#include <nlohmann/json.hpp>

namespace cmm::daemon {

std::optional<std::string> job_notification(const std::string& topic, const std::string& payload) {
  const std::size_t slash = topic.rfind('/');
  if (slash == std::string::npos) return std::nullopt;
  const std::string what = topic.substr(slash + 1);
  if (what != "state" && what != "progress") return std::nullopt;
  const nlohmann::json params = nlohmann::json::parse(payload, nullptr, false);
  if (!params.is_object() || !params.contains("job") || !params["job"].is_number_integer()) return std::nullopt;
  return nlohmann::json{{"jsonrpc", "2.0"}, {"method", "job." + what}, {"params", params}}.dump(
      -1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string unique_client_id(const std::string& program) {
  char host[64] = {};
  gethostname(host, sizeof host - 1);
  std::random_device random;
  char id[160];
  std::snprintf(id, sizeof id, "%s-%s-%d-%08x", program.c_str(), host, static_cast<int>(getpid()), random());
  return id;
}

StationLink::StationLink(StationAddress address, Clock::time_point deadline) : address_(std::move(address)) {
  MqttConnect& broker = address_.broker;
  if (broker.client_id.empty()) broker.client_id = unique_client_id("cmmctl");
  const std::string base = address_.topic_prefix + "/" + address_.station + "/";
  // The station learns who asks from the topic, which the broker's ACL lets only this user publish
  // on; it answers only under clients/<that user>/, which only this user may read (docs/fleet.md).
  const std::string user = broker.username.empty() ? "anonymous" : broker.username;
  request_topic_ = base + "api/request/" + user;
  jobs_filter_ = base + "jobs/+/+";
  status_topic_ = base + "status";
  reply_topic_ = address_.topic_prefix + "/clients/" + user + "/" + broker.client_id + "/reply";
  MqttCallbacks callbacks;
  callbacks.connected = [this] {
    // Subscribed before anything is sent: the broker handles one client's packets in order.
    client_->subscribe(reply_topic_, 1);
    client_->subscribe(jobs_filter_, 0);
    client_->subscribe(status_topic_, 1);
    std::lock_guard lock(mutex_);
    connected_ = true;
    arrived_.notify_all();
  };
  callbacks.failed = [this](const std::string& why) {
    std::lock_guard lock(mutex_);
    if (failure_.empty()) failure_ = why;
    arrived_.notify_all();
  };
  callbacks.message = [this](const MqttMessage& m) {
    std::string line;
    if (m.topic == status_topic_) {
      const nlohmann::json status = nlohmann::json::parse(m.payload, nullptr, false);
      std::lock_guard lock(mutex_);
      online_ = status.is_object() && status.value("online", nlohmann::json(false)) == true;
      status_seen_ = true;
      arrived_.notify_all();
      return;
    }
    if (m.topic == reply_topic_) {
      line = m.payload;
    } else if (auto notification = job_notification(m.topic, m.payload)) {
      line = std::move(*notification);
    } else {
      return;  // anything else a shared broker carries there is not ours to read
    }
    std::lock_guard lock(mutex_);
    lines_.push_back(std::move(line));
    arrived_.notify_all();
  };
  client_ = std::make_unique<MqttClient>(broker, std::move(callbacks));
  client_->start();
  std::unique_lock lock(mutex_);
  if (!arrived_.wait_until(lock, deadline, [this] { return connected_ || !failure_.empty(); }) || !connected_) {
    const std::string why = failure_.empty() ? "no answer" : failure_;
    lock.unlock();
    client_->stop();
    throw std::runtime_error("cannot reach the MQTT broker at " + client_->broker() + ": " + why);
  }
  // A station's retained status comes right after the subscription: without one there is no such
  // station on this broker, and an offline one cannot answer. Either is said now, not after a
  // call's timeout.
  arrived_.wait_until(lock, std::min(deadline, Clock::now() + std::chrono::seconds(1)), [this] { return status_seen_; });
  if (!status_seen_ || !online_) {
    const bool seen = status_seen_;
    lock.unlock();
    client_->stop();
    throw std::runtime_error(seen ? "station " + address_.station + " is offline on " + client_->broker()
                                  : "no station " + address_.station + " on the broker at " + client_->broker() +
                                        " (cmmctl fleet lists them)");
  }
}

StationLink::~StationLink() { client_->stop(); }

void StationLink::send(std::string_view text) {
  // A caller's bytes may hold several lines (a raw write): each is one request.
  while (!text.empty()) {
    const std::size_t end = text.find('\n');
    const std::string_view line = text.substr(0, end);
    text = end == std::string_view::npos ? std::string_view() : text.substr(end + 1);
    if (line.empty()) continue;
    MqttMessage m;
    m.topic = request_topic_;
    m.payload = std::string(line);
    m.qos = 1;
    m.response_topic = reply_topic_;
    {
      std::lock_guard lock(mutex_);
      m.correlation = std::to_string(next_correlation_++);
    }
    if (!address_.token.empty()) m.user_properties.emplace_back("token", address_.token);
    if (!client_->publish(m)) throw std::runtime_error(name() + ": the broker link is down");
  }
}

std::optional<std::string> StationLink::next_line(Clock::time_point deadline) {
  std::unique_lock lock(mutex_);
  if (!arrived_.wait_until(lock, deadline, [this] { return !lines_.empty(); })) return std::nullopt;
  std::string line = std::move(lines_.front());
  lines_.pop_front();
  return line;
}

std::string StationLink::name() const {
  return "mqtt://" + client_->broker() + "/" + address_.topic_prefix + "/" + address_.station;
}

}  // namespace cmm::daemon
