// MqttStation: notifications to topics, the outbox's deliveries, and api/request on two threads of
// its own (a long machine.home over the broker leaves one for the next request).
#include "daemon/mqtt_station.hpp"

#include <asio/post.hpp>
#include <asio/thread_pool.hpp>
#include <spdlog/spdlog.h>

#include "daemon/mqtt_request.hpp"
#include "hal/utc_time.hpp"

namespace cmm::daemon {

namespace {

using nlohmann::json;

bool is_end(const std::string& state) { return state == "done" || state == "failed" || state == "cancelled"; }

}  // namespace

StationTopics station_topics(const std::string& prefix, const std::string& station) {
  return {prefix + "/" + station + "/", prefix + "/clients/"};
}

struct MqttStation::Requests {
  asio::thread_pool pool{2};
  std::atomic<std::size_t> pending{0};
  std::atomic<bool> accepting{true};
};

MqttStation::MqttStation(MqttOptions options, std::string version, const std::filesystem::path& state_dir,
                         const RpcDispatcher& dispatcher, TokenBook& tokens, MqttRequestLimits limits)
    : options_(std::move(options)),
      version_(std::move(version)),
      topics_(station_topics(options_.topic_prefix, options_.station)),
      dispatcher_(dispatcher),
      tokens_(tokens),
      limits_(limits),
      outbox_(state_dir / "mqtt-outbox"),
      requests_(std::make_unique<Requests>()) {
  MqttConnect connect;
  connect.host = options_.broker;
  connect.port = options_.port;
  connect.client_id = "cmmd-" + options_.station;
  connect.username = options_.username;
  connect.password = options_.password;
  connect.tls = options_.tls;
  connect.keepalive_s = options_.keepalive_s;
  MqttMessage will;
  will.topic = topics_.status();
  will.payload = json{{"station", options_.station}, {"online", false}}.dump();
  will.qos = 1;
  will.retain = true;
  connect.will = will;
  MqttCallbacks callbacks;
  callbacks.connected = [this] { on_connected(); };
  callbacks.disconnected = [this](const std::string& why) {
    if (requests_ && !requests_->accepting) return;  // stop(): leaving is the point
    spdlog::warn("MQTT {}: link down ({}); {} state(s) and result(s) kept until it returns", client_->broker(), why,
                 outbox_.size());
  };
  callbacks.failed = [this](const std::string& why) {
    // Once per reason: a broker away for a night would otherwise write a line every 5 s.
    std::lock_guard lock(mutex_);
    if (why == last_failure_) return;
    last_failure_ = why;
    spdlog::warn("MQTT {}: cannot connect ({}); trying again every few seconds", client_->broker(), why);
  };
  callbacks.message = [this](const MqttMessage& m) { on_request(m); };
  callbacks.published = [this](int mid) {
    std::lock_guard lock(mutex_);
    if (const auto it = in_flight_.find(mid); it != in_flight_.end()) {
      outbox_.remove(it->second);
      in_flight_.erase(it);
    }
  };
  client_ = std::make_unique<MqttClient>(std::move(connect), std::move(callbacks));
}

MqttStation::~MqttStation() { stop(); }

void MqttStation::start() {
  spdlog::info("MQTT: station {} on {} under {}", options_.station, client_->broker(), topics_.base);
  client_->start();
}

void MqttStation::stop() {
  if (!requests_) return;
  requests_->accepting = false;
  requests_->pool.join();  // running requests finish and reply before the link goes
  client_->stop();
  requests_.reset();
}

bool MqttStation::connected() const { return client_->connected(); }

void MqttStation::on_connected() {
  spdlog::info("MQTT {}: connected as station {}", client_->broker(), options_.station);
  client_->subscribe(topics_.request(), 1);
  std::lock_guard lock(mutex_);
  last_failure_.clear();
  publish_status();
  // Whatever was waiting, oldest first; a message already sent but not acknowledged goes again
  // (QoS 1 is at least once: a reader keys states by job and time).
  in_flight_.clear();
  for (const OutboxEntry& entry : outbox_.pending())
    if (const auto mid = client_->publish(entry.message)) in_flight_[*mid] = entry.seq;
}

void MqttStation::publish_status() {
  MqttMessage status;
  status.topic = topics_.status();
  status.payload = json{{"station", options_.station}, {"online", true},       {"version", version_},
                        {"machine", machine_},         {"job", job_},          {"updated", hal::utc_now()}}
                       .dump();
  status.qos = 1;
  status.retain = true;
  client_->publish(status);  // when down, the next connect publishes the status as it is then
}

void MqttStation::send_kept(const MqttMessage& message) {
  const std::uint64_t seq = outbox_.add(message);
  if (const auto mid = client_->publish(message)) in_flight_[*mid] = seq;
}

void MqttStation::notify(const std::string& method, const json& params) {
  try {
    std::lock_guard lock(mutex_);
    if (method == "machine.state") {
      machine_ = params;
      publish_status();
    } else if (method == "job.state") {
      const int id = params.at("job").get<int>();
      const std::string state = params.at("state").get<std::string>();
      MqttMessage m;
      m.topic = topics_.job(id, "state");
      json payload = params;
      payload["station"] = options_.station;
      payload["time"] = hal::utc_now();
      m.payload = payload.dump();
      m.qos = 1;
      m.retain = true;
      send_kept(m);
      if (is_end(state)) {
        m.topic = topics_.job(id, "result");
        send_kept(m);
        last_progress_.erase(id);
      }
      if (!is_end(state) && state != "queued") job_ = {{"id", id}, {"state", state}};
      else if (job_.is_object() && job_["id"] == id) job_ = nullptr;
      publish_status();
    } else if (method == "job.progress") {
      const int id = params.at("job").get<int>();
      const auto now = std::chrono::steady_clock::now();
      auto& last = last_progress_[id];
      const bool finished = params.value("done", 0) >= params.value("total", 1);
      if (!finished && now - last < std::chrono::duration<double>(options_.progress_interval_s)) return;
      last = now;
      MqttMessage m;
      m.topic = topics_.job(id, "progress");
      m.payload = params.dump();
      client_->publish(m);  // QoS 0 and not kept: the next one says more
    }
  } catch (const std::exception& e) {
    // The broker's side of a notification must never reach the job that sent it.
    spdlog::error("MQTT: {} not published: {}", method, e.what());
  }
}

void MqttStation::on_request(const MqttMessage& message) {
  if (message.topic != topics_.request() || !requests_ || !requests_->accepting) return;
  const MqttAdmission admission = admit_mqtt_request(message, topics_.replies, limits_.max_request_bytes, tokens_);
  if (admission.kind == MqttAdmission::Kind::ignore) {
    std::lock_guard lock(mutex_);
    if (!ignored_logged_)
      spdlog::warn("MQTT: a request with response topic \"{}\" ignored: replies go only under {} (said once)",
                   message.response_topic, topics_.replies);
    ignored_logged_ = true;
    return;
  }
  if (admission.kind == MqttAdmission::Kind::refuse) return reply(message, admission.refusal);
  if (requests_->pending.fetch_add(1) >= limits_.max_pending) {
    requests_->pending.fetch_sub(1);
    reply(message, error_response(nullptr, RpcError(rpc_code::server_busy, "too many MQTT requests waiting",
                                                    {{"max_pending", limits_.max_pending}})));
    return;
  }
  asio::post(requests_->pool, [this, message, role = admission.role] {
    std::uint64_t id;
    {
      std::lock_guard lock(mutex_);
      id = next_context_++;
    }
    const auto response = answer_mqtt_request(
        message, role, dispatcher_, {.max_depth = 128, .max_batch_entries = limits_.max_batch_entries}, id);
    if (response) reply(message, *response);
    requests_->pending.fetch_sub(1);
  });
}

void MqttStation::reply(const MqttMessage& request, const json& response) {
  MqttMessage m;
  m.topic = request.response_topic;
  m.correlation = request.correlation;
  m.payload = to_wire(response);
  m.qos = 1;
  try {
    if (!client_->publish(m)) spdlog::warn("MQTT: reply to {} lost: the link is down", request.response_topic);
  } catch (const MqttError& e) {
    spdlog::warn("{}", e.what());  // a response topic the broker refuses
  }
}

}  // namespace cmm::daemon
