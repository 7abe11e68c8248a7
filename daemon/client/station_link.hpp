// cmmctl's side of a station on a fleet's broker (docs/fleet.md): JSON-RPC lines out as requests on
// <prefix>/<station>/api/request/<user> (the token as a user property), replies in on this client's own
// response topic <prefix>/clients/<user>/<client id>/reply, and the station's job topics turned
// into job.state and job.progress notifications, so RpcClient works over it as over a socket.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include "daemon/client/mqtt_client.hpp"

namespace cmm::daemon {

struct StationAddress {
  MqttConnect broker;                 // its client_id is made here when empty
  std::string topic_prefix = "cmmd";
  std::string station;
  std::string token;                  // sent with every request; "" sends none
};

class StationLink {
 public:
  using Clock = std::chrono::steady_clock;
  // Waits for the broker and the station's status until `deadline`; throws MqttError (settings)
  // or std::runtime_error (the first attempt failed, with why; no answer by then; no such station;
  // the station offline).
  StationLink(StationAddress address, Clock::time_point deadline);
  ~StationLink();

  void send(std::string_view line);  // one JSON-RPC message, without its newline
  std::optional<std::string> next_line(Clock::time_point deadline);
  std::string name() const;          // "mqtt://HOST:PORT/<prefix>/<station>", for messages

 private:
  StationAddress address_;
  std::string reply_topic_, request_topic_, jobs_filter_, status_topic_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<std::string> lines_;
  bool connected_ = false;
  std::string failure_;  // why the first attempt to connect failed
  bool status_seen_ = false, online_ = false;  // the station's retained status
  std::uint64_t next_correlation_ = 1;
  std::unique_ptr<MqttClient> client_;
};

// The notification line a socket client would get for a message on <base>jobs/<id>/state or
// .../progress: {"jsonrpc", "method": "job.state"|"job.progress", "params": payload}; nothing for
// another topic or a payload that is not such an object.
std::optional<std::string> job_notification(const std::string& topic, const std::string& payload);

// A client id no other cmmctl on the broker has: cmmctl-<host>-<pid>-<random>.
std::string unique_client_id(const std::string& program);

}  // namespace cmm::daemon
