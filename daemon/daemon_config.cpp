// cmmd.json read in one pass: the server, the folders, the log, the machine (whose block its driver
// reads), the descriptions jobs are planned for, and the job defaults.
#include "daemon/daemon_config.hpp"

#include <cstdlib>

#include <unistd.h>

#include <asio/ip/address.hpp>

#include "daemon/driver_factory.hpp"
#include "daemon/static_files.hpp"
#include "hal/description/json_fields.hpp"
#include "planner/tolerances_json.hpp"

namespace cmm::daemon {

namespace {

// systemd hands the directories it made through the environment; they win over the file.
std::filesystem::path from_environment(const char* variable, const std::filesystem::path& fallback) {
  const char* value = std::getenv(variable);
  if (value == nullptr || *value == '\0') return fallback;
  std::string first(value);
  if (const auto colon = first.find(':'); colon != std::string::npos) first.resize(colon);
  return first;
}

void read_server(description::JsonFields& b, DaemonConfig& c) {
  ServerOptions& s = c.server;
  s.tcp_bind = b.text("tcp_bind", s.tcp_bind);
  s.tcp_port = b.integer("tcp_port", s.tcp_port, 0, 65535);
  s.tcp_enabled = b.flag("tcp_enabled", s.tcp_enabled);
  const std::string socket = b.text("unix_socket", "cmmd.sock");
  s.unix_path = socket.empty() ? std::string() : description::resolve_config_path(socket, c.runtime_dir).string();
  const std::string mode = b.text("unix_mode", "0660");
  try {
    std::size_t used = 0;
    s.unix_mode = static_cast<unsigned>(std::stoul(mode, &used, 8));
    if (used != mode.size() || s.unix_mode > 0777) throw std::invalid_argument(mode);
  } catch (const std::exception&) {
    b.problem("unix_mode", "must be an octal mode such as \"0660\"");
  }
  s.max_request_bytes = static_cast<std::size_t>(b.number("max_request_bytes", static_cast<double>(s.max_request_bytes), 1024, 1 << 30));
  s.max_batch_entries = static_cast<std::size_t>(b.integer("max_batch_entries", static_cast<int>(s.max_batch_entries), 1, 100000));
  s.max_connections = b.integer("max_connections", s.max_connections, 1, 100000);
  s.max_unix_connections = b.integer("max_unix_connections", s.max_unix_connections, 1, 100000);
  s.max_unauthenticated_connections =
      b.integer("max_unauthenticated_connections", s.max_unauthenticated_connections, 1, 100000);
  s.max_pending_requests = b.integer("max_pending_requests", s.max_pending_requests, 1, 100000);
  s.idle_timeout_s = b.number("idle_timeout_s", s.idle_timeout_s, 0.01, 86400);
  s.auth_timeout_s = b.number("auth_timeout_s", s.auth_timeout_s, 0.01, 86400);
  s.max_unsent_bytes = static_cast<std::size_t>(b.number("max_unsent_bytes", static_cast<double>(s.max_unsent_bytes), 1 << 16, 1ull << 34));
  s.max_total_unsent_bytes = static_cast<std::size_t>(
      b.number("max_total_unsent_bytes", static_cast<double>(s.max_total_unsent_bytes), 1 << 16, 1ull << 36));
  if (s.max_total_unsent_bytes < s.max_unsent_bytes)
    b.problem("max_total_unsent_bytes", "must be at least max_unsent_bytes");
  s.workers.operator_threads = b.integer("worker_threads", s.workers.operator_threads, 1, 64);
  s.workers.observer_threads = b.integer("observer_threads", s.workers.observer_threads, 1, 64);
  s.workers.planning_threads = b.integer("planning_threads", s.workers.planning_threads, 1, 64);
  s.workers.max_queued_planning = b.integer("max_queued_planning", s.workers.max_queued_planning, 0, 10000);
  s.workers.max_waiting_bytes = static_cast<std::size_t>(
      b.number("max_waiting_request_bytes", static_cast<double>(s.workers.max_waiting_bytes), 1 << 20, 1ull << 34));
  if (s.workers.max_waiting_bytes < s.max_request_bytes)
    b.problem("max_waiting_request_bytes", "must be at least max_request_bytes, or a request of that size never runs");
  s.tokens.clear();
  for (description::JsonFields token : b.objects("tokens")) {
    AccessToken t;
    t.token = token.text("token", "");
    if (t.token.size() < 16) token.problem("token", "must be at least 16 characters");
    t.role = role_from_string(token.text("role", "observer", {"observer", "operator"}));
    token.finish();
    s.tokens.push_back(t);
  }
  // Refused here as well as in RpcServer::start, so `cmmd --check` says it before systemd starts
  // cmmd; a host name only resolves at start and is checked there.
  asio::error_code not_an_address;
  const asio::ip::address address = asio::ip::make_address(s.tcp_bind, not_an_address);
  if (s.tcp_enabled && s.tokens.empty() && !not_an_address && !address.is_loopback())
    b.problem("tcp_bind", "\"" + s.tcp_bind + "\" is not a loopback address and no server.tokens are set (anyone " +
                              "who reaches the port could move the machine); set tokens or bind 127.0.0.1");
  b.finish();
}

// The dashboard's server listens on server.tcp_bind: the same loopback rule holds for it.
void read_http(description::JsonFields& b, DaemonConfig& c, const std::filesystem::path& base_dir) {
  HttpOptions& h = c.http;
  h.enabled = b.flag("enabled", h.enabled);
  h.port = b.integer("port", h.port, 0, 65535);
  h.allowed_origins.clear();
  for (description::JsonFields origin : b.items("allowed_origins")) {
    const std::string text = origin.as_text("");
    const std::size_t scheme = text.find("://");
    const std::string_view rest = scheme == std::string::npos ? std::string_view() : std::string_view(text).substr(scheme + 3);
    if ((!text.starts_with("http://") && !text.starts_with("https://")) || rest.empty() ||
        rest.find('/') != std::string_view::npos)
      origin.problem("must be an origin such as \"http://station.example:7621\" (scheme, host, port; no path)");
    h.allowed_origins.push_back(text);
  }
  const std::string root = b.text("web_root", "");
  h.web_root = root.empty() ? default_web_root() : description::resolve_config_path(root, base_dir);
  asio::error_code not_an_address;
  const asio::ip::address address = asio::ip::make_address(c.server.tcp_bind, not_an_address);
  if (h.enabled && c.server.tokens.empty() && !not_an_address && !address.is_loopback())
    b.problem("enabled", "the dashboard would listen on server.tcp_bind \"" + c.server.tcp_bind + "\", not a loopback " +
                             "address, and no server.tokens are set; set tokens, bind 127.0.0.1 or disable it");
  b.finish();
}

// A name inside a topic: MQTT's wildcards and separators would put it under other topics.
void check_topic_part(description::JsonFields& b, const char* key, const std::string& text, bool slashes) {
  if (text.empty() || text.find_first_of(slashes ? "+#" : "+#/") != std::string::npos || text.front() == '/' ||
      text.back() == '/' || text.starts_with("$"))
    b.problem(key, std::string("must be a topic ").append(slashes ? "prefix" : "level").append(
                       " without + # $ or a leading or trailing /, not \"" + text + "\""));
}

void read_mqtt(description::JsonFields& b, MqttOptions& m, const std::filesystem::path& base_dir) {
  m.enabled = b.flag("enabled", m.enabled);
  m.broker = b.text("broker", m.broker);
  m.port = b.integer("port", m.port, 1, 65535);
  m.username = b.text("username", "");
  m.password = b.text("password", "");
  m.station = b.text("station", "");
  if (!m.station.empty()) check_topic_part(b, "station", m.station, false);
  m.topic_prefix = b.text("topic_prefix", m.topic_prefix);
  check_topic_part(b, "topic_prefix", m.topic_prefix, true);
  m.keepalive_s = b.integer("keepalive_s", m.keepalive_s, 5, 3600);
  // Not below 0.1 s: a message a touch costs the job thread a wake-up of the network thread per
  // touch (+14 to +24 % per touch in bench/fleet_bench, docs/PERFORMANCE.md).
  m.progress_interval_s = b.number("progress_interval_s", m.progress_interval_s, 0.1, 3600);
  if (b.has("tls")) {
    description::JsonFields tls = b.object("tls");
    auto file = [&](const char* key) {
      const std::string text = tls.text(key, "");
      return text.empty() ? std::string() : description::resolve_config_path(text, base_dir).string();
    };
    m.tls.ca_file = file("ca_file");
    m.tls.cert_file = file("cert_file");
    m.tls.key_file = file("key_file");
    if (m.tls.ca_file.empty()) tls.problem("ca_file", "is needed for TLS (the broker's CA, PEM)");
    if (m.tls.cert_file.empty() != m.tls.key_file.empty())
      tls.problem("cert_file", "a client certificate needs both cert_file and key_file");
    tls.finish();
  }
  b.finish();
}

}  // namespace

std::string default_station_name() {
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) != 0 || name[0] == '\0') return "cmmd";
  return name;
}

DaemonConfig daemon_config_from_json(const nlohmann::json& j, const std::string& source,
                                     const std::filesystem::path& base_dir) {
  DaemonConfig c;
  c.source = source;
  description::JsonFields block(j);
  block.expect_object();
  description::JsonFields server = block.object("server");
  c.state_dir =
      from_environment("STATE_DIRECTORY", description::resolve_config_path(block.text("state_dir", "/var/lib/cmmd"), base_dir));
  c.runtime_dir =
      from_environment("RUNTIME_DIRECTORY", description::resolve_config_path(block.text("runtime_dir", "/run/cmmd"), base_dir));
  c.models_dir = description::resolve_config_path(block.text("models_dir", ""), base_dir);
  read_server(server, c);
  {
    description::JsonFields http = block.object("http");
    read_http(http, c, base_dir);
  }
  {
    description::JsonFields log = block.object("log");
    c.log_level = log.text("level", "info", {"trace", "debug", "info", "warn", "error", "critical", "off"});
    log.finish();
  }
  // What jobs are planned for: the named description, else the one the driver's block gives (the
  // simulator's, a Grbl machine's), else the built-in default.
  description::MachineDescription fallback = description::default_machine();
  {
    description::JsonFields machine = block.object("machine");
    const std::size_t problems = block.problem_count();
    if (machine.present() && machine.value().is_object()) {
      c.machine = machine.value();
      // Only the driver's name is read here; the rest of the block is its driver's to read, below.
      const std::string name = machine.text("driver", c.driver, driver_names());
      if (block.problem_count() == problems) c.driver = canonical_driver_name(name);
    }
    c.machine["driver"] = c.driver;
    // The driver reads its block now, so that `cmmd --check` names every bad key of it (under
    // /machine), and says whether its configuration describes the machine.
    if (block.problem_count() == problems) {
      const std::unique_ptr<hal::Cmm> driver = make_driver(c.driver, base_dir.string());
      try {
        driver->configure(c.machine);
        if (const auto described = driver->configured_machine()) fallback = *described;
      } catch (const description::FieldError& e) {
        block.problems_of(e, "machine");
      }
    }
  }
  c.description = description::described(block, "machine_description", fallback, base_dir,
                                         description::machine_from_json, description::read_machine);
  c.plate = description::described(block, "plate", description::default_plate(), base_dir,
                                   description::plate_from_json, description::read_plate);
  {
    description::JsonFields job = block.object("job");
    c.job.delta_mm = job.number("delta_mm", c.job.delta_mm, 0.001, 10);
    c.job.spacing_mm = job.number("spacing_mm", c.job.spacing_mm, 0.05, 100);
    c.job.feature_angle_deg = job.number("feature_angle_deg", c.job.feature_angle_deg, 1, 179);
    c.job.trigger_sigma_mm = job.number("trigger_sigma_mm", c.job.trigger_sigma_mm, 0, 1);
    job.finish();
  }
  {
    description::JsonFields jog = block.object("jog");
    c.jog.max_speed_mm_s = jog.number("max_speed_mm_s", c.jog.max_speed_mm_s, 0.01, 1000);
    if (c.jog.max_speed_mm_s > c.description.max_speed_mm_s)
      jog.problem("max_speed_mm_s", std::string("must not exceed the machine's max_speed_mm_s (")
                                        .append(nlohmann::json(c.description.max_speed_mm_s).dump())
                                        .append(")"));
    c.jog.segment_s = jog.number("segment_s", c.jog.segment_s, 0.01, 1);
    jog.finish();
  }
  if (block.has("tolerances")) {
    description::JsonFields tolerances = block.object("tolerances");
    c.tolerances = planner::read_tolerances(tolerances, c.tolerances);
  }
  // "" (or absent) is the host's name: one config file can serve every station of a fleet.
  if (const std::string station = block.text("station", ""); !station.empty()) c.station = station;
  {
    description::JsonFields mqtt = block.object("mqtt");
    read_mqtt(mqtt, c.mqtt, base_dir);
    if (c.mqtt.station.empty()) c.mqtt.station = c.station;
    if (c.mqtt.enabled) check_topic_part(mqtt, "station", c.mqtt.station, false);
  }
  block.finish();
  block.throw_if_problems(source);
  return c;
}

DaemonConfig read_daemon_config(const std::filesystem::path& file) {
  return daemon_config_from_json(description::read_json_file(file, "cmmd's config"), file.string(),
                                 file.parent_path());
}

std::vector<std::string> changes_needing_restart(const DaemonConfig& running, const DaemonConfig& next) {
  std::vector<std::string> changed;
  ServerOptions a = running.server, b = next.server;
  a.tokens.clear(), b.tokens.clear();
  if (a != b) changed.push_back("server (other than tokens)");
  if (running.http != next.http) changed.push_back("http");
  if (running.job.delta_mm != next.job.delta_mm || running.job.spacing_mm != next.job.spacing_mm ||
      running.job.feature_angle_deg != next.job.feature_angle_deg ||
      running.job.trigger_sigma_mm != next.job.trigger_sigma_mm)
    changed.push_back("job");
  if (running.jog.max_speed_mm_s != next.jog.max_speed_mm_s || running.jog.segment_s != next.jog.segment_s)
    changed.push_back("jog");
  if (running.tolerances != next.tolerances) changed.push_back("tolerances");
  if (running.station != next.station) changed.push_back("station");
  if (running.mqtt != next.mqtt) changed.push_back("mqtt");
  if (running.state_dir != next.state_dir) changed.push_back("state_dir");
  if (running.runtime_dir != next.runtime_dir) changed.push_back("runtime_dir");
  if (running.models_dir != next.models_dir) changed.push_back("models_dir");
  if (running.machine != next.machine) changed.push_back("machine");
  if (description::to_json(running.description) != description::to_json(next.description))
    changed.push_back("machine_description");
  if (description::to_json(running.plate) != description::to_json(next.plate)) changed.push_back("plate");
  return changed;
}

}  // namespace cmm::daemon
