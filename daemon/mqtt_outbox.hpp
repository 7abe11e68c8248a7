// The messages a station must deliver at least once (job states and results): each is a file in
// <state_dir>/mqtt-outbox until the broker acknowledges it, so neither a broker down for hours nor
// a cmmd restart in between loses one.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
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

}  // namespace cmm::daemon
