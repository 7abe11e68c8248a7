// MqttStation: notifications to topics, the outbox's deliveries, and api/request/<user>: quick
// methods (machine.stop) answered at once, slow ones on two threads of its own (a long machine.home
// over the broker leaves one for the next request).
#include "daemon/mqtt_station.hpp"

#include <optional>

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
      gate_(dispatcher,
            {.max_request_bytes = limits.max_request_bytes,
             .max_batch_entries = limits.max_batch_entries,
             .max_pending_requests = limits.max_pending},
            Framing::messages),
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
  client_->subscribe(topics_.requests() + "+", 1);
  std::lock_guard lock(mutex_);
  last_failure_.clear();
  publish_status();
  // Whatever was waiting, oldest first; a message already sent but not acknowledged goes again
  // (QoS 1 is at least once: a reader keys states by job and time).
  in_flight_.clear();
  for (const OutboxEntry& entry : outbox_.pending())
    if (const auto mid = client_->publish(entry.message)) in_flight_[*mid] = entry.seq;
  // The broker may have come back without what it had acknowledged (killed between two saves of
  // its database). CONNACK's session-present flag cannot tell: cmmd connects with a clean start,
  // so it is 0 on every connect, lost retained messages or not. So every connect sends them all
  // again, after the outbox so that each job's latest state is the one retained.
  for (const RecentJobStates::Entry& job : recent_.entries()) publish_recent(job);
}

void MqttStation::publish_recent(const RecentJobStates::Entry& job) {
  MqttMessage m;
  m.topic = topics_.job(job.id, "state");
  m.payload = job.payload;
  m.qos = 1;
  m.retain = true;
  client_->publish(m);
  if (!job.ended) return;
  m.topic = topics_.job(job.id, "result");
  client_->publish(m);
}

void MqttStation::recall_jobs(const json& records) {
  std::lock_guard lock(mutex_);
  std::optional<json> held;  // the last job recalled that holds the station (running, paused, interrupted)
  for (const json& record : records) {
    try {
      const int id = record.at("id").get<int>();
      const std::string state = record.at("state").get<std::string>();
      const json payload = {{"job", id},
                            {"state", state},
                            {"reason", record.at("reason")},
                            {"verdict", record.value("verdict", json(nullptr))},
                            {"station", options_.station},
                            {"time", record.at("updated")}};
      const RecentJobStates::Entry job{.id = id, .ended = is_end(state), .payload = payload.dump()};
      if (!recent_.add_if_unknown(job)) continue;
      publish_recent(job);  // when down (as at start), the connect sends it
      if (!job.ended && state != "queued") held = json{{"id", id}, {"state", state}};
    } catch (const json::exception& e) {
      spdlog::error("MQTT: a job record not recalled ({}): {}", e.what(), record.dump());
    }
  }
  if (held && job_.is_null()) {
    job_ = *held;
    publish_status();
  }
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
      recent_.set({.id = id, .ended = is_end(state), .payload = m.payload});
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
  if (!requests_ || !requests_->accepting) return;
  MqttAdmission admission = admit_mqtt_request(message, topics_.requests(), topics_.replies, tokens_);
  if (admission.kind == MqttAdmission::Kind::ignore) {
    std::lock_guard lock(mutex_);
    if (!ignored_logged_)
      spdlog::warn("MQTT: a request on \"{}\" with response topic \"{}\" ignored: requests come on {}<user>, replies "
                   "go only under {}<that user>/ (said once)",
                   message.topic, message.response_topic, topics_.requests(), topics_.replies);
    ignored_logged_ = true;
    return;
  }
  if (admission.kind == MqttAdmission::Kind::refuse) return reply(message, to_wire(admission.refusal));
  // On the broker's thread: quick methods (machine.stop among them) are answered here and never
  // wait behind slow ones, whoever fills the queue.
  std::shared_ptr<RpcContext> ctx = admission.context;
  // The station's queue is shared by all requesters (pending 0: no per-client count over MQTT).
  GateDecision d = gate_.admit(message.payload, *ctx, 0, [this](Work, std::size_t count, std::size_t) {
    if (requests_->pending.fetch_add(count) + count <= limits_.max_pending) return std::optional<std::string>();
    requests_->pending.fetch_sub(count);
    return std::optional<std::string>("too many MQTT requests waiting (max_pending " + std::to_string(limits_.max_pending) + ")");
  });
  switch (d.kind) {
    case GateDecision::Kind::nothing: return;
    case GateDecision::Kind::answer:
    case GateDecision::Kind::close:  // a message is not a stream: nothing to close, the error is the answer
      if (d.answer) reply(message, to_wire(*d.answer));
      return;
    case GateDecision::Kind::run: break;
  }
  asio::post(requests_->pool, [this, message, ctx, d = std::move(d)] {
    if (const std::optional<std::string> response = gate_.run(d.message, *ctx)) reply(message, *response);
    requests_->pending.fetch_sub(d.count);
  });
}

void MqttStation::reply(const MqttMessage& request, const std::string& response) {
  MqttMessage m;
  m.topic = request.response_topic;
  m.correlation = request.correlation;
  m.payload = response;
  m.qos = 1;
  try {
    if (!client_->publish(m)) spdlog::warn("MQTT: reply to {} lost: the link is down", request.response_topic);
  } catch (const MqttError& e) {
    spdlog::warn("{}", e.what());  // a response topic the broker refuses
  }
}

}  // namespace cmm::daemon
