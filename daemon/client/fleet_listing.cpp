// list_fleet: one subscription, collected until the broker falls quiet.
#include "daemon/client/fleet_listing.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>

#include "daemon/client/station_link.hpp"

namespace cmm::daemon {

std::vector<nlohmann::json> list_fleet(MqttConnect broker, const std::string& topic_prefix, double connect_timeout_s,
                                       double quiet_s, double max_s) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](double s) { return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s)); };
  std::mutex mutex;
  std::condition_variable changed;
  bool connected = false;
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
  callbacks.message = [&](const MqttMessage& m) {
    nlohmann::json status = nlohmann::json::parse(m.payload, nullptr, false);
    if (!status.is_object()) return;  // not a station's: ignored, as a reader of a shared broker must
    const std::string station = m.topic.substr(topic_prefix.size() + 1, m.topic.size() - topic_prefix.size() - 8);
    status["station"] = station;
    std::lock_guard lock(mutex);
    stations[station] = std::move(status);
    last = Clock::now();
    changed.notify_all();
  };
  MqttClient client(broker, std::move(callbacks));
  self = &client;
  client.start();
  std::unique_lock lock(mutex);
  if (!changed.wait_for(lock, seconds(connect_timeout_s), [&] { return connected; }))
    throw std::runtime_error("no MQTT broker answered at " + client.broker());
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
