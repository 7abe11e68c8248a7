// MqttOutbox: one JSON file per message, named by its number so that a listing sorts them.
#include "daemon/mqtt_outbox.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "geometry/atomic_file.hpp"

namespace cmm::daemon {

namespace {

std::filesystem::path file_of(const std::filesystem::path& folder, std::uint64_t seq) {
  char name[40];
  std::snprintf(name, sizeof name, "%020llu.json", static_cast<unsigned long long>(seq));
  return folder / name;
}

MqttMessage read_entry(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) throw std::runtime_error("cannot read it");
  const nlohmann::json j = nlohmann::json::parse(text.str());
  MqttMessage m;
  m.topic = j.at("topic").get<std::string>();
  m.payload = j.at("payload").get<std::string>();
  m.qos = j.at("qos").get<int>();
  m.retain = j.at("retain").get<bool>();
  return m;
}

}  // namespace

MqttOutbox::MqttOutbox(std::filesystem::path folder) : folder_(std::move(folder)) {
  std::filesystem::create_directories(folder_);
  for (const auto& item : std::filesystem::directory_iterator(folder_)) {
    const std::filesystem::path& file = item.path();
    if (file.extension() != ".json") continue;  // temp files of a crashed write, *.bad
    try {
      const std::uint64_t seq = std::stoull(file.stem().string());
      entries_.emplace(seq, read_entry(file));
      next_ = std::max(next_, seq + 1);
    } catch (const std::exception& e) {
      spdlog::error("MQTT outbox: {} is unreadable ({}); set aside as .bad", file.string(), e.what());
      std::error_code ignored;
      std::filesystem::rename(file, std::filesystem::path(file).replace_extension(".bad"), ignored);
    }
  }
  if (!entries_.empty()) spdlog::info("MQTT outbox: {} message(s) from before wait for the broker", entries_.size());
}

std::uint64_t MqttOutbox::add(const MqttMessage& message) {
  std::lock_guard lock(mutex_);
  const std::uint64_t seq = next_++;
  const nlohmann::json j = {
      {"topic", message.topic}, {"payload", message.payload}, {"qos", message.qos}, {"retain", message.retain}};
  try {
    geometry::write_atomically(file_of(folder_, seq), j.dump());
  } catch (const std::exception& e) {
    spdlog::error("MQTT outbox: {} kept in memory only: {}", message.topic, e.what());
  }
  MqttMessage kept;
  kept.topic = message.topic;
  kept.payload = message.payload;
  kept.qos = message.qos;
  kept.retain = message.retain;
  entries_.emplace(seq, std::move(kept));
  return seq;
}

void MqttOutbox::remove(std::uint64_t seq) {
  std::lock_guard lock(mutex_);
  if (entries_.erase(seq) == 0) return;
  std::error_code ec;
  std::filesystem::remove(file_of(folder_, seq), ec);
  if (ec) spdlog::warn("MQTT outbox: cannot remove {}: {}", file_of(folder_, seq).string(), ec.message());
}

std::vector<OutboxEntry> MqttOutbox::pending() const {
  std::lock_guard lock(mutex_);
  std::vector<OutboxEntry> out;
  out.reserve(entries_.size());
  for (const auto& [seq, message] : entries_) out.push_back({seq, message});
  return out;
}

std::size_t MqttOutbox::size() const {
  std::lock_guard lock(mutex_);
  return entries_.size();
}

void RecentJobStates::set(Entry entry) {
  const int id = entry.id;
  jobs_.insert_or_assign(id, std::move(entry));
  trim();
}

bool RecentJobStates::add_if_unknown(Entry entry) {
  const int id = entry.id;
  if (!jobs_.try_emplace(id, std::move(entry)).second) return false;
  trim();
  return jobs_.contains(id);  // an ended job older than every one kept is not recent
}

std::vector<RecentJobStates::Entry> RecentJobStates::entries() const {
  std::vector<Entry> out;
  out.reserve(jobs_.size());
  for (const auto& [id, entry] : jobs_) out.push_back(entry);
  return out;
}

void RecentJobStates::trim() {
  std::size_t ended = 0;
  for (const auto& [id, entry] : jobs_) ended += entry.ended ? 1 : 0;
  for (auto it = jobs_.begin(); ended > max_ended_ && it != jobs_.end();) {
    if (!it->second.ended) {
      ++it;
      continue;
    }
    it = jobs_.erase(it);
    --ended;
  }
}

}  // namespace cmm::daemon
