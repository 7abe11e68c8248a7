// The station on a fleet's MQTT broker (docs/fleet.md): its retained status with a last will, each
// job's state, progress and result, and JSON-RPC requests on api/request/<user> answered on the
// requester's own response topic. States and results go through the on-disk outbox, so a broker
// that is away loses none of them and never holds up a job; and every connect publishes again the
// status and the latest state and result of each recent job, so a broker that lost its retained
// messages (killed before it saved them) gets them back from the station.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/client/json_rpc.hpp"
#include "daemon/client/mqtt_client.hpp"
#include "daemon/mqtt_options.hpp"
#include "daemon/mqtt_outbox.hpp"
#include "daemon/request_gate.hpp"
#include "daemon/token_book.hpp"

namespace cmm::daemon {

struct MqttRequestLimits {
  std::size_t max_request_bytes = 1 << 20;
  std::size_t max_batch_entries = 128;
  std::size_t max_pending = 16;  // slow requests waiting or running; more are answered server_busy
};

// The topics of one station.
struct StationTopics {
  std::string base;  // <prefix>/<station>/
  std::string status() const { return base + "status"; }
  std::string requests() const { return base + "api/request/"; }  // + the requester's broker user name
  std::string replies;  // <prefix>/clients/: where requesters' response topics must lie, under their user
  std::string job(int id, const std::string& what) const { return base + "jobs/" + std::to_string(id) + "/" + what; }
};
StationTopics station_topics(const std::string& prefix, const std::string& station);

class MqttStation {
 public:
  // The dispatcher and the token book must outlive the station.
  MqttStation(MqttOptions options, std::string version, const std::filesystem::path& state_dir,
              const RpcDispatcher& dispatcher, TokenBook& tokens, MqttRequestLimits limits);
  ~MqttStation();

  void start();  // connects in the background; returns at once
  void stop();   // answers nothing more, waits for running requests, leaves with the last will

  // From cmmd's notification fan-out (any thread): machine.state and job.* become topics.
  void notify(const std::string& method, const nlohmann::json& params);
  // job.list's records, read once the job store has recovered: the states no notification
  // announces (the interrupted of a job a crash cut short) become retained topics too. A job a
  // notification already told of keeps what that said.
  void recall_jobs(const nlohmann::json& records);
  bool connected() const;
  std::size_t unsent() const { return outbox_.size(); }  // states and results not yet acknowledged

 private:
  void on_connected();
  void on_request(const MqttMessage& message);
  void send_kept(const MqttMessage& message);
  void publish_status();  // under mutex_
  void publish_recent(const RecentJobStates::Entry& job);  // under mutex_; not kept: the next connect sends it again
  void reply(const MqttMessage& request, const std::string& response);

  MqttOptions options_;
  std::string version_;
  StationTopics topics_;
  RequestGate gate_;
  TokenBook& tokens_;
  MqttRequestLimits limits_;
  MqttOutbox outbox_;

  mutable std::mutex mutex_;
  nlohmann::json machine_ = nullptr;  // the last machine.state
  nlohmann::json job_ = nullptr;      // {"id", "state"} of the job running, or null
  RecentJobStates recent_;
  std::map<int, std::uint64_t> in_flight_;  // message id → outbox number
  std::map<int, std::chrono::steady_clock::time_point> last_progress_;
  std::string last_failure_;  // the last reason a connect failed, logged once
  bool ignored_logged_ = false;  // a request not on a user's topic or without a usable response topic: said once

  struct Requests;
  std::unique_ptr<Requests> requests_;  // the threads requests run on
  std::unique_ptr<MqttClient> client_;
};

}  // namespace cmm::daemon
