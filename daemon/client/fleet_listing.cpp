// list_fleet: one subscription, collected until the broker falls quiet.
#include "daemon/client/fleet_listing.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>

#include "daemon/client/station_link.hpp"

namespace cmm::daemon {

std::optional<nlohmann::json> fleet_entry(const std::string& topic, const std::string& topic_prefix,
                                          const std::string& payload) {
  const std::string head = topic_prefix + "/", tail = "/status";
  if (topic.size() <= head.size() + tail.size() || !topic.starts_with(head) || !topic.ends_with(tail))
    return std::nullopt;
  const std::string station = topic.substr(head.size(), topic.size() - head.size() - tail.size());
  nlohmann::json status = nlohmann::json::parse(payload, nullptr, false);
  if (!status.is_object() || station.find('/') != std::string::npos) return std::nullopt;
  status["station"] = station;  // the topic's word, not the payload's
  return status;
}

namespace {

// A member as text, whatever a station (or anyone on the broker) put there.
std::string text_of(const nlohmann::json& object, const char* key) {
  if (!object.is_object()) return "?";
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return "?";
  return it->is_string() ? it->get<std::string>() : it->dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

const nlohmann::json& member(const nlohmann::json& object, const char* key) {
  static const nlohmann::json none;
  if (!object.is_object()) return none;
  const auto it = object.find(key);
  return it == object.end() ? none : *it;
}

}  // namespace

std::string fleet_line(const nlohmann::json& status) {
  const nlohmann::json &machine = member(status, "machine"), &job = member(status, "job");
  const bool online = member(status, "online") == true;
  std::string line = text_of(status, "station");
  line.resize(std::max<std::size_t>(line.size(), 16), ' ');
  line.append(online ? " online " : " OFFLINE");
  if (machine.is_object()) {
    line.append("  machine ").append(text_of(machine, "link")).append(" (").append(text_of(machine, "lifecycle")).append(")");
    if (member(machine, "fault").is_object()) line.append(" fault ").append(text_of(member(machine, "fault"), "kind"));
  }
  if (job.is_object()) line.append("  job ").append(text_of(job, "id")).append(" ").append(text_of(job, "state"));
  else if (online) line.append("  idle");
  return line;
}

std::vector<nlohmann::json> list_fleet(MqttConnect broker, const std::string& topic_prefix, double connect_timeout_s,
                                       double quiet_s, double max_s) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](double s) { return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s)); };
  std::mutex mutex;
  std::condition_variable changed;
  bool connected = false;
  std::string failure;  // the first attempt's, if it failed
  Clock::time_point last = Clock::now();
  std::map<std::string, nlohmann::json> stations;
  const std::string filter = topic_prefix + "/+/status";
  if (broker.client_id.empty()) broker.client_id = unique_client_id("cmmctl-fleet");
  MqttCallbacks callbacks;
  MqttClient* self = nullptr;
  callbacks.connected = [&] {
    self->subscribe(filter, 1);
    std::lock_guard lock(mutex);
    connected = true;
    last = Clock::now();
    changed.notify_all();
  };
  callbacks.failed = [&](const std::string& why) {
    std::lock_guard lock(mutex);
    if (failure.empty()) failure = why;
    changed.notify_all();
  };
  callbacks.message = [&](const MqttMessage& m) {
    std::optional<nlohmann::json> status = fleet_entry(m.topic, topic_prefix, m.payload);
    if (!status) return;  // not a station's: ignored, as a reader of a shared broker must
    const std::string station = (*status)["station"].get<std::string>();
    std::lock_guard lock(mutex);
    stations[station] = std::move(*status);
    last = Clock::now();
    changed.notify_all();
  };
  MqttClient client(broker, std::move(callbacks));
  self = &client;
  client.start();
  std::unique_lock lock(mutex);
  if (!changed.wait_for(lock, seconds(connect_timeout_s), [&] { return connected || !failure.empty(); }) || !connected)
    throw std::runtime_error("cannot reach the MQTT broker at " + client.broker() + ": " +
                             (failure.empty() ? "no answer" : failure));
  const Clock::time_point end = Clock::now() + seconds(max_s);
  while (Clock::now() < end) {
    const Clock::time_point quiet_end = last + seconds(quiet_s);
    if (Clock::now() >= quiet_end) break;
    changed.wait_until(lock, std::min(quiet_end, end));
  }
  std::vector<nlohmann::json> out;
  for (auto& [name, status] : stations) out.push_back(std::move(status));
  lock.unlock();
  client.stop();
  return out;
}

}  // namespace cmm::daemon
