// What cmmd counts for monitoring, and its Prometheus text exposition (format 0.0.4) that /metrics
// serves (docs/fleet.md): touches, jobs by final state and by verdict, job and touch durations, machine faults,
// the link, JSON-RPC requests and errors by method, connected clients.
#pragma once

#include <chrono>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace cmm::daemon {

// A Prometheus histogram: cumulative counts at each upper bound, and the sum and count.
struct Histogram {
  std::vector<double> bounds;  // ascending, +Inf implied
  std::vector<long long> counts = std::vector<long long>(bounds.size(), 0);
  double sum = 0;
  long long count = 0;

  void observe(double value);
};

// What is read at scrape time rather than counted.
struct MetricsGauges {
  long long socket_clients = 0;     // JSON-RPC over TCP and the Unix socket
  long long websocket_clients = 0;  // the dashboard's
};

// The fleet broker's link, with mqtt.enabled only (docs/fleet.md): up, and the job states and
// results waiting in the outbox for it.
struct MqttGauges {
  bool link_up = false;
  long long unsent = 0;
};

class Metrics {
 public:
  using Clock = std::chrono::steady_clock;

  // `methods`: the API's method names; requests for any other name are counted as "other", so that
  // a client cannot grow the label set.
  explicit Metrics(std::set<std::string> methods);

  // A notification as cmmd sends it to subscribers (docs/api.md, Notifications), at time `now`.
  void observe(const std::string& method, const nlohmann::json& params, Clock::time_point now = Clock::now());
  // One answered JSON-RPC request; `method` as the request named it ("" when it named none).
  void count_request(const std::string& method, bool error);

  std::string text(const MetricsGauges& gauges, const std::optional<MqttGauges>& mqtt = std::nullopt) const;

 private:
  mutable std::mutex mutex_;
  const std::set<std::string> methods_;
  long long touches_ = 0;
  std::map<std::string, long long> jobs_by_state_;
  std::map<std::string, long long> verdicts_;  // done jobs by verdict
  std::map<std::string, long long> faults_by_kind_;
  std::map<std::string, long long> requests_, errors_;
  int link_up_ = 0;
  std::string last_fault_;
  Histogram job_seconds_{{1, 5, 15, 30, 60, 120, 300, 600, 1200, 1800, 3600, 7200}};
  Histogram touch_seconds_{{0.1, 0.25, 0.5, 1, 1.5, 2, 3, 5, 10, 30}};
  std::map<int, Clock::time_point> job_started_, last_touch_;
};

}  // namespace cmm::daemon
