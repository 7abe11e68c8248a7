// The messages a station must deliver at least once (job states and results): each is a file in
// <state_dir>/mqtt-outbox until the broker acknowledges it, so neither a broker down for hours nor
// a cmmd restart in between loses one. And the latest state of each recent job, which the station
// publishes again on every connect, for a broker that lost what it had acknowledged.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "daemon/client/mqtt_client.hpp"

namespace cmm::daemon {

struct OutboxEntry {
  std::uint64_t seq = 0;  // the order they were added in, across restarts
  MqttMessage message;
};

// Thread-safe: the job thread adds, the MQTT thread removes.
class MqttOutbox {
 public:
  // Reads what an earlier run left in `folder` (created if missing); an unreadable file is logged and
  // set aside as *.bad, never deleted.
  explicit MqttOutbox(std::filesystem::path folder);

  // Keeps `message` (topic, payload, qos, retain) and returns its number. A disk that refuses the
  // file (full, read-only) is logged: the message is still kept in memory and sent.
  std::uint64_t add(const MqttMessage& message);
  // The broker has it: forgotten, file and all. Unknown numbers are ignored (a duplicate ack).
  void remove(std::uint64_t seq);
  std::vector<OutboxEntry> pending() const;  // oldest first
  std::size_t size() const;

 private:
  std::filesystem::path folder_;
  mutable std::mutex mutex_;
  std::map<std::uint64_t, MqttMessage> entries_;
  std::uint64_t next_ = 1;
};

// The last jobs/<id>/state payload of each recent job. A broker acknowledges a message before it
// writes it to disk (Mosquitto saves every autosave_interval), and one killed in between comes back
// without it, with the outbox's copy long gone: so the station publishes these again whenever it
// connects. Recent: every job not ended yet, and the `max_ended` ended ones with the highest ids.
// Not thread-safe: the station holds its lock.
class RecentJobStates {
 public:
  struct Entry {
    int id = 0;
    bool ended = false;  // done, failed or cancelled: jobs/<id>/result carries the same payload
    std::string payload;
  };

  explicit RecentJobStates(std::size_t max_ended = 100) : max_ended_(max_ended) {}

  void set(Entry entry);  // a state just published: replaces what was known of the job
  // A state read back from the job store: kept only if nothing newer is known of the job (a
  // notification that came first is at least as new). Returns whether it was kept.
  bool add_if_unknown(Entry entry);
  std::vector<Entry> entries() const;  // by job id

 private:
  void trim();  // the oldest ended jobs beyond max_ended_ forgotten

  std::size_t max_ended_;
  std::map<int, Entry> jobs_;
};

}  // namespace cmm::daemon
