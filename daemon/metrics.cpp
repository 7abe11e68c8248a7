// Counting from cmmd's notifications and answered requests; the exposition format is Prometheus's
// text format 0.0.4 (one HELP and TYPE line per family, then its samples).
#include "daemon/metrics.hpp"

#include <algorithm>

#include <spdlog/fmt/fmt.h>

namespace cmm::daemon {

namespace {

const std::set<std::string> kFinalStates = {"done", "failed", "cancelled", "interrupted"};
// A done job's verdicts (docs/result.md): a fixed label set, so that a record cannot grow it.
const std::set<std::string> kVerdicts = {"pass", "fail", "undecided", "incomplete"};

// A label value with \, " and newline escaped, as the format asks.
std::string escaped(const std::string& value) {
  std::string out;
  for (const char c : value) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

void family(std::string& out, const char* name, const char* type, const char* help) {
  out += fmt::format("# HELP {} {}\n# TYPE {} {}\n", name, help, name, type);
}

void labelled(std::string& out, const char* name, const char* label, const std::map<std::string, long long>& values) {
  for (const auto& [key, value] : values) out += fmt::format("{}{{{}=\"{}\"}} {}\n", name, label, escaped(key), value);
}

void histogram(std::string& out, const char* name, const Histogram& h) {
  for (std::size_t i = 0; i < h.bounds.size(); ++i) out += fmt::format("{}_bucket{{le=\"{}\"}} {}\n", name, h.bounds[i], h.counts[i]);
  out += fmt::format("{}_bucket{{le=\"+Inf\"}} {}\n{}_sum {}\n{}_count {}\n", name, h.count, name, h.sum, name, h.count);
}

double seconds_between(Metrics::Clock::time_point from, Metrics::Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

}  // namespace

void Histogram::observe(double value) {
  for (std::size_t i = 0; i < bounds.size(); ++i)
    if (value <= bounds[i]) ++counts[i];
  sum += value;
  ++count;
}

Metrics::Metrics(std::set<std::string> methods) : methods_(std::move(methods)) {}

void Metrics::observe(const std::string& method, const nlohmann::json& params, Clock::time_point now) {
  std::lock_guard lock(mutex_);
  if (method == "job.state") {
    const int job = params.value("job", -1);
    const std::string state = params.value("state", "");
    if (state == "queued") return;
    job_started_.try_emplace(job, now);  // its first step out of the queue (or a resume after a restart)
    // A pause is no touch's time: the next touch counts from the resume.
    if (state == "paused") last_touch_.erase(job);
    else last_touch_.try_emplace(job, now);
    if (!kFinalStates.contains(state)) return;
    ++jobs_by_state_[state];
    if (const nlohmann::json* v = params.contains("verdict") ? &params["verdict"] : nullptr; v && v->is_object()) {
      const std::string verdict = v->value("verdict", "");
      ++verdicts_[kVerdicts.contains(verdict) ? verdict : "other"];
    }
    job_seconds_.observe(seconds_between(job_started_[job], now));
    job_started_.erase(job);
    last_touch_.erase(job);
  } else if (method == "job.touch") {
    ++touches_;
    const int job = params.value("job", -1);
    if (const auto last = last_touch_.find(job); last != last_touch_.end()) touch_seconds_.observe(seconds_between(last->second, now));
    last_touch_.insert_or_assign(job, now);
  } else if (method == "machine.state") {
    link_up_ = params.value("link", "") == "up" ? 1 : 0;
    const nlohmann::json& fault = params.contains("fault") ? params["fault"] : nlohmann::json();
    const std::string kind = fault.is_object() ? fault.value("kind", "unknown") : "";
    if (!kind.empty() && kind != last_fault_) ++faults_by_kind_[kind];
    last_fault_ = kind;
  }
}

void Metrics::count_request(const std::string& method, bool error) {
  const std::string name = methods_.contains(method) ? method : "other";
  std::lock_guard lock(mutex_);
  ++requests_[name];
  if (error) ++errors_[name];
}

std::string Metrics::text(const MetricsGauges& gauges, const std::optional<MqttGauges>& mqtt) const {
  std::lock_guard lock(mutex_);
  std::string out;
  family(out, "cmmd_touches_total", "counter", "Touches the machine made in jobs.");
  out += fmt::format("cmmd_touches_total {}\n", touches_);
  family(out, "cmmd_jobs_total", "counter", "Jobs that ended, by final state (interrupted: stopped with cmmd, resumable).");
  std::map<std::string, long long> jobs;
  for (const std::string& state : kFinalStates) jobs[state] = 0;
  for (const auto& [state, n] : jobs_by_state_) jobs[state] = n;
  labelled(out, "cmmd_jobs_total", "state", jobs);
  family(out, "cmmd_job_verdicts_total", "counter",
         "Done jobs with a nominal, by verdict (incomplete: a feature asked for was not measured).");
  std::map<std::string, long long> verdicts;
  for (const std::string& verdict : kVerdicts) verdicts[verdict] = 0;
  for (const auto& [verdict, n] : verdicts_) verdicts[verdict] = n;
  labelled(out, "cmmd_job_verdicts_total", "verdict", verdicts);
  family(out, "cmmd_job_duration_seconds", "histogram", "From a job's start to its final state, pauses included.");
  histogram(out, "cmmd_job_duration_seconds", job_seconds_);
  family(out, "cmmd_touch_duration_seconds", "histogram",
         "From a job's previous touch (or its start or resume) to the next: travel, approach and contact.");
  histogram(out, "cmmd_touch_duration_seconds", touch_seconds_);
  family(out, "cmmd_machine_faults_total", "counter", "Machine faults by kind, as the machine monitor saw them appear.");
  labelled(out, "cmmd_machine_faults_total", "kind", faults_by_kind_);
  family(out, "cmmd_machine_link_up", "gauge", "1 when the link to the machine is up.");
  out += fmt::format("cmmd_machine_link_up {}\n", link_up_);
  family(out, "cmmd_rpc_requests_total", "counter", "JSON-RPC requests answered, by method (\"other\": no such method).");
  labelled(out, "cmmd_rpc_requests_total", "method", requests_);
  family(out, "cmmd_rpc_errors_total", "counter", "JSON-RPC requests answered with an error, by method.");
  labelled(out, "cmmd_rpc_errors_total", "method", errors_);
  family(out, "cmmd_connected_clients", "gauge", "Open JSON-RPC connections, by transport.");
  out += fmt::format("cmmd_connected_clients{{transport=\"socket\"}} {}\ncmmd_connected_clients{{transport=\"websocket\"}} {}\n",
                     gauges.socket_clients, gauges.websocket_clients);
  if (mqtt) {
    family(out, "cmmd_mqtt_link_up", "gauge", "1 when the link to the fleet's MQTT broker is up.");
    out += fmt::format("cmmd_mqtt_link_up {}\n", mqtt->link_up ? 1 : 0);
    family(out, "cmmd_mqtt_unsent_messages", "gauge", "Job states and results kept until the broker acknowledges them.");
    out += fmt::format("cmmd_mqtt_unsent_messages {}\n", mqtt->unsent);
  }
  return out;
}

}  // namespace cmm::daemon
