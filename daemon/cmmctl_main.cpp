// cmmctl: the operator's command line for cmmd — submit a model and watch the job, query and steer
// jobs and the machine, list serial ports. Talks JSON-RPC over the Unix socket or TCP.
#include <CLI/CLI.hpp>
#include <cctype>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>

#include "daemon/client/fleet_listing.hpp"
#include "daemon/client/model_upload.hpp"
#include "daemon/client/progress_bar.hpp"
#include "daemon/client/rpc_client.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/client/taught_corners.hpp"
#include "geometry/atomic_file.hpp"
#include "hal/serial_ports.hpp"

namespace {

using namespace cmm;
using namespace cmm::daemon;
using nlohmann::json;

struct Global {
  std::string endpoint;
  std::string token, token_file;
  bool raw_json = false;
  // A fleet's broker (docs/fleet.md): `fleet` reads it, --station sends every command through it.
  std::string broker, broker_user, broker_password, topic_prefix = "cmmd", station;
  MqttTls broker_tls;
};

std::string from_env(const std::string& given, const char* variable) {
  if (!given.empty()) return given;
  const char* value = std::getenv(variable);
  return value ? value : "";
}

// --broker HOST[:PORT] (or $CMMD_BROKER); 1883, or 8883 with TLS, when no port is given.
MqttConnect broker_of(const Global& g) {
  MqttConnect c;
  const std::string broker = from_env(g.broker, "CMMD_BROKER");
  if (broker.empty()) throw std::runtime_error("no broker: give --broker HOST[:PORT] or set $CMMD_BROKER");
  const std::size_t colon = broker.rfind(':');
  c.host = colon == std::string::npos ? broker : broker.substr(0, colon);
  c.tls = g.broker_tls;
  c.port = colon == std::string::npos ? (c.tls.ca_file.empty() ? 1883 : 8883) : std::stoi(broker.substr(colon + 1));
  c.username = from_env(g.broker_user, "CMMD_BROKER_USER");
  c.password = from_env(g.broker_password, "CMMD_BROKER_PASSWORD");
  return c;
}

void print_fleet(const std::vector<json>& stations, bool raw_json) {
  if (raw_json) {
    std::cout << json(stations).dump(1, ' ', false, json::error_handler_t::replace) << "\n";
    return;
  }
  if (stations.empty()) std::printf("no station has a status on this broker\n");
  for (const json& s : stations) std::printf("%s\n", fleet_line(s).c_str());
}

std::string default_endpoint() {
  if (const char* e = std::getenv("CMMD_ENDPOINT"); e != nullptr && *e != '\0') return e;
  if (std::filesystem::exists("/run/cmmd/cmmd.sock")) return "unix:/run/cmmd/cmmd.sock";
  return "tcp://127.0.0.1:7620";
}

// The station's operator token cmmd keeps for local tools (docs/api.md, Access): readable by the
// members of cmmd's group.
constexpr const char* kStationTokenFile = "/var/lib/cmmd/operator.token";

// Whether a tcp:// endpoint is this host's: only there may the station token file be sent unasked.
bool loopback_endpoint(const std::string& endpoint) {
  std::string host = endpoint.substr(std::string("tcp://").size());
  host = host.substr(0, host.rfind(':'));
  return host == "localhost" || host == "[::1]" || host == "::1" || host.starts_with("127.");
}

// --token or $CMMD_TOKEN; else the first line of --token-file, $CMMD_TOKEN_FILE or, for TCP to this
// host, the station token file when it can be read. "" when there is none.
std::string token_of(const Global& g, bool local_tcp) {
  if (std::string token = from_env(g.token, "CMMD_TOKEN"); !token.empty()) return token;
  std::string file = from_env(g.token_file, "CMMD_TOKEN_FILE");
  const bool named = !file.empty();
  if (!named && local_tcp) file = kStationTokenFile;
  if (file.empty()) return {};
  std::ifstream in(file);
  std::string token;
  if (in) std::getline(in, token);
  if (token.empty() && named) throw std::runtime_error("cannot read a token from " + file);
  return token;
}

RpcClient connect(const Global& g) {
  if (const std::string station = from_env(g.station, "CMMD_STATION"); !station.empty())
    return RpcClient::connect_station({broker_of(g), g.topic_prefix, station, token_of(g, false)});  // on each request
  const std::string endpoint = g.endpoint.empty() ? default_endpoint() : g.endpoint;
  const bool tcp = endpoint.starts_with("tcp://");
  const std::string token = token_of(g, tcp && loopback_endpoint(endpoint));
  RpcClient client = RpcClient::connect(endpoint);
  if (!token.empty()) client.call("server.auth", {{"token", token}});
  else if (tcp)
    std::fprintf(stderr, "cmmctl: no token for %s: only server.info answers (use the Unix socket, --token, --token-file "
                 "or $CMMD_TOKEN; the station's is %s, readable by cmmd's group)\n", endpoint.c_str(), kStationTokenFile);
  return client;
}

json read_json_file(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file + ": cannot be opened");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {  // out_of_range too: a number like 1e400
    throw std::runtime_error(file + ": not JSON: " + e.what());
  }
}

// A corners or measure_plate file as the job request carries it: cmmd cannot read the client's
// files, so a "plate" that names one (relative to the file naming it) is sent inline.
json registration_file(const std::string& file) {
  json j = read_json_file(file);
  if (j.is_object() && j.contains("plate") && j["plate"].is_string()) {
    std::filesystem::path plate = j["plate"].get<std::string>();
    if (plate.is_relative()) plate = std::filesystem::path(file).parent_path() / plate;
    j["plate"] = read_json_file(plate.string());
  }
  return j;
}

std::string fmt(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

void print_record(const json& r) {
  std::printf("job %d  %-11s %s%s\n", r.at("id").get<int>(), r.at("state").get<std::string>().c_str(),
              r.value("name", "").c_str(), r.value("reason", "").empty() ? "" : ("  — " + r["reason"].get<std::string>()).c_str());
}

std::string counts_text(const json& c) {
  return std::to_string(c.value("pass", 0)).append(" pass, ") + std::to_string(c.value("fail", 0)).append(" fail, ") +
         std::to_string(c.value("undecided", 0)).append(" undecided, ") +
         std::to_string(c.value("not_measured", 0)).append(" not measured, ") +
         std::to_string(c.value("excluded", 0)).append(" excluded");
}

// A characteristic that did not pass: its deviation against the tolerance, or why it has none.
std::string characteristic_text(const json& c, const json& reason) {
  if (c.value("verdict", "") == "not_measured")
    return "not measured" + (reason.is_string() ? ": " + reason.get<std::string>() : std::string());
  const json& t = c.at("tolerance_mm");
  return fmt("%+.4f mm", c.value("deviation_mm", 0.0)) + fmt(" (U %.4f, ", c.value("uncertainty_mm", 0.0)) +
         fmt("tolerance [%+.4f, ", t.at(0).get<double>()) + fmt("%+.4f]) ", t.at(1).get<double>()) +
         c.value("verdict", "");
}

// Whether a characteristic is listed under the verdict: every one asked for that did not pass.
bool not_passed(const json& c) {
  const std::string v = c.value("verdict", "");
  return v != "pass" && v != "excluded";
}

// The inspection's verdict with its coverage, its counts, and the features that did not pass,
// not measured ones included (the first 20 of them).
void print_verdict(const json& result) {
  const json& inspection = result.value("inspection", json(nullptr));
  if (inspection.is_null()) {
    std::printf("verdict     none: the job named no nominal model (deviations are against the scan)\n");
    return;
  }
  std::string verdict = inspection.value("verdict", "");
  for (char& c : verdict) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  const json& nominal = inspection.at("nominal");
  // The verdict is only as true as what it covers: the coverage goes on the verdict's own line.
  std::printf("verdict     %s: %s\n", verdict.c_str(), inspection.value("coverage", "").c_str());
  std::printf("            against %s (%s)\n", nominal.value("model", "").c_str(), nominal.value("method", "").c_str());
  std::printf("            edge points %s\n", counts_text(inspection.at("counts").at("edge_points")).c_str());
  std::printf("            holes       %s\n", counts_text(inspection.at("counts").at("holes")).c_str());
  for (const json& note : inspection.value("notes", json::array()))
    if (note.is_string()) std::printf("            note: %s\n", note.get<std::string>().c_str());
  int shown = 0;
  for (const json& e : result.at("edge_points")) {
    const json& i = e.value("inspection", json(nullptr));
    if (i.is_null() || !not_passed(i)) continue;
    if (shown++ < 20) std::printf("  edge %-5d %s\n", e.at("id").get<int>(), characteristic_text(i, i.value("reason", json())).c_str());
  }
  for (const json& h : result.at("holes")) {
    const json& i = h.value("inspection", json(nullptr));
    if (i.is_null()) continue;
    for (const char* which : {"diameter", "position"}) {
      const json& c = i.at(which);
      if (!not_passed(c)) continue;
      if (shown++ < 20)
        std::printf("  hole %-3d %-8s %s\n", h.at("id").get<int>(), which, characteristic_text(c, i.value("reason", json())).c_str());
    }
  }
  if (shown > 20) std::printf("  ... and %d more not passed (cmmctl result ID --json)\n", shown - 20);
}

// The result as an operator reads it: what was found, touched, registered and how far it is off.
void print_result_summary(const json& result) {
  const json& s = result.at("summary");
  const json& e = s.at("edge_points");
  const json& h = s.at("holes");
  const auto id = [](const json& v) { return v.is_number() ? " (point " + std::to_string(v.get<int>()) + ")" : std::string(); };
  std::printf("features    %d edge points, %d holes\n", e.value("total", 0), h.value("total", 0));
  std::printf("measured    %d edge points (%d failed, %d not probeable); %d of %d holes\n", e.value("measured", 0),
              e.value("failed", 0), e.value("not_planned", 0), h.value("measured", 0), h.value("total", 0));
  if (result.contains("touches")) std::printf("touches     %d\n", result["touches"].get<int>());
  if (const json reg = result.value("registration", json(nullptr)); reg.is_object())
    std::printf("register    %s, RMS residual %.4f mm\n", result.value("registration_method", "").c_str(),
                reg.value("rms_mm", 0.0));
  std::printf("deviation   edges vs reference: RMS %.4f mm, max %.4f mm%s; worst 1-sigma %.4f mm\n",
              s.value("rms_deviation_mm", 0.0), s.value("max_deviation_mm", 0.0),
              id(s.value("max_deviation_id", json(nullptr))).c_str(), s.value("worst_sigma_mm", 0.0));
  std::printf("holes       max centre deviation %.4f mm, max diameter deviation %.4f mm\n",
              s.value("max_centre_deviation_mm", 0.0), s.value("max_diameter_deviation_mm", 0.0));
  if (result.contains("machine_time_s"))
    std::printf("machine     %s of machine time\n", duration_text(result["machine_time_s"].get<double>()).c_str());
  print_verdict(result);
}

// Follows a job until it ends; a paused job is waited on (another terminal may resume it).
int watch(RpcClient& client, int id) {
  client.call("server.subscribe", {{"topics", {"job"}}});
  const bool tty = isatty(STDERR_FILENO) != 0;
  json record = client.call("job.get", {{"job", id}});
  std::string last_state;
  int last_tenth = -1;
  for (;;) {
    const std::string state = record.at("state").get<std::string>();
    if (state != last_state) {
      if (tty) std::fprintf(stderr, "\n");
      std::fprintf(stderr, "job %d: %s%s\n", id, state.c_str(),
                   record.value("reason", "").empty() ? "" : (" (" + record["reason"].get<std::string>() + ")").c_str());
      if (state == "paused" || state == "interrupted")
        std::fprintf(stderr, "  cmmctl resume %d continues it, cmmctl cancel %d ends it\n", id, id);
      last_state = state;
    }
    if (state == "done") return 0;
    if (state == "failed" || state == "cancelled") return 1;
    const std::optional<json> n = client.wait_notification(2.0);
    if (!n) {
      record = client.call("job.get", {{"job", id}});  // a missed notification is caught up here
      continue;
    }
    const json& p = n->at("params");
    if (p.value("job", -1) != id) continue;
    if (n->at("method") == "job.progress") {
      const int done = p.value("done", 0), total = p.value("total", 0);
      const std::string line = progress_line(p.value("phase", ""), done, total, p.value("eta_s", 0.0));
      if (tty) {
        std::fprintf(stderr, "\r%s", line.c_str());
      } else if (const int tenth = total > 0 ? done * 10 / total : 0; tenth != last_tenth) {
        std::fprintf(stderr, "%s\n", line.c_str());
        last_tenth = tenth;
      }
    } else if (n->at("method") == "job.state") {
      record = client.call("job.get", {{"job", id}});
    }
  }
}

// plan.preview for a person: the model's size in mm first (a model in the wrong unit shows there),
// then what the plan would measure, its time, and what the dry run ran into; --json gives the reply.
void print_preview_summary(const std::string& model, const json& p) {
  const json& mesh = p.at("reference_mesh");
  std::printf("model      %s: %lld vertices, %lld triangles%s\n", model.c_str(), mesh.value("vertices", 0LL),
              mesh.value("faces", 0LL), mesh.value("scan", json(nullptr)).is_null() ? "" : " (meshed from a raw scan)");
  if (const json e = mesh.value("extent_mm", json(nullptr)); e.is_array())
    std::printf("extent     %.1f × %.1f × %.1f mm\n", e[0].get<double>(), e[1].get<double>(), e[2].get<double>());
  const json& f = p.at("features");
  std::printf("points     %lld edge points, %lld with a way to probe them; %lld holes\n", f.value("edge_points", 0LL),
              f.value("probeable", 0LL), f.value("holes", 0LL));
  std::printf("touches    %lld with tip %s (r %.3f mm)\n", p.value("touches", 0LL), p.value("tip", "?").c_str(),
              p.value("probe_radius", 0.0));
  const json& d = p.at("dry_run");
  std::printf("estimate   %.0f s (lower bound %.0f s); the dry run took %.0f s\n", p.at("estimate").value("time_s", 0.0),
              p.at("estimate").value("lower_bound_s", 0.0), d.value("time_s", 0.0));
  const long long misses = d.value("misses", 0LL), early = d.value("early_triggers", 0LL),
                  travel = d.value("out_of_travel", 0LL), other = d.value("other_faults", 0LL);
  if (misses + early + travel + other == 0) std::printf("problems   none in the dry run\n");
  else
    std::printf("problems   %lld misses, %lld early triggers, %lld out of travel, %lld other faults\n", misses, early,
                travel, other);
  int shown = 0;
  for (const json& problem : d.value("problems", json::array())) {
    if (shown++ == 5) {
      std::printf("           … (cmmctl --json preview lists them all)\n");
      break;
    }
    std::printf("           touch %d %s%s%s\n", problem.value("touch", -1), problem.value("kind", "?").c_str(),
                problem.contains("message") ? ": " : "", problem.value("message", "").c_str());
  }
  for (const json& note : p.value("notes", json::array())) std::printf("note       %s\n", note.get<std::string>().c_str());
}

// How a raw scan is meshed (docs/api.md, Job request): sent only when given, so cmmd's defaults hold.
struct ScanFlags {
  double tolerance_mm = 0.05;
  double bin_size_mm = 0;
  bool adaptive = false;
};

json job_request(const std::string& model, const CLI::App& submit, double scale, double delta, double spacing,
                 double angle, const ScanFlags& scan, std::uint64_t seed, const std::string& name,
                 const std::string& corners, const std::string& measure) {
  json r = {{"model", model}, {"seed", seed}};
  // Sent only when given: an explicit scale is the operator's word on the model's unit, which cmmd's
  // unit check then does not second-guess; --units-checked says so with the scale left at 1.
  if (submit.count("--scale")) r["scale"] = scale;
  if (submit.count("--units-checked")) r["units_checked"] = true;
  if (submit.count("--delta")) r["delta_mm"] = delta;
  if (submit.count("--spacing")) r["spacing_mm"] = spacing;
  if (submit.count("--feature-angle")) r["feature_angle_deg"] = angle;
  if (submit.count("--tolerance")) r["tolerance_mm"] = scan.tolerance_mm;
  if (submit.count("--bin-size")) r["bin_size_mm"] = scan.bin_size_mm;
  if (scan.adaptive) r["adaptive"] = true;
  if (!name.empty()) r["name"] = name;
  if (!corners.empty()) r["registration"] = registration_file(corners);
  else if (!measure.empty()) r["registration"] = {{"measure_plate", registration_file(measure)}};
  return r;
}

volatile std::sig_atomic_t interrupted = 0;

// A hal::Fault's message names its kind already ("CommLost: cannot reach …"); another error's does not.
std::string fault_text(const std::string& kind, const std::string& message) {
  return message.starts_with(kind + ":") ? message : kind + ": " + message;
}

std::string position_text(const json& p) {
  return fmt("(%.4f, ", p.at(0).get<double>()) + fmt("%.4f, ", p.at(1).get<double>()) + fmt("%.4f)", p.at(2).get<double>());
}

// A step jog: machine.jog, then machine.status until that jog has ended. Ctrl-C stops it (the
// operator let go). 0 when it ended by itself (its distance, or a face of the travel box), 1 when a
// fault ended it (a contact: EarlyTrigger; a stop: Aborted), 130 on Ctrl-C.
int step_jog(RpcClient& client, const json& params, double distance_mm, bool raw_json) {
  const json started = client.call("machine.jog", params, 60);
  const int id = started.at("jog").get<int>();
  const double speed_mm_s = started.at("speed_mm_s").get<double>();
  std::signal(SIGINT, [](int) { interrupted = 1; });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(2 * distance_mm / speed_mm_s + 30);
  json status;
  for (;;) {
    status = client.call("machine.status");
    const json& jog = status.value("jog", json(nullptr));
    if (jog.is_null() || jog.value("id", 0) != id) break;
    if (interrupted != 0 || std::chrono::steady_clock::now() > deadline) {
      client.call("machine.jog_stop");
      if (interrupted == 0) throw std::runtime_error(std::string("jog ").append(std::to_string(id)).append(" did not end in time: stopped"));
      std::fprintf(stderr, "cmmctl jog: interrupted: jog %d stopped\n", id);
      return 130;
    }
    usleep(50000);
  }
  const json& last = status.value("last_jog", json(nullptr));
  const bool mine = last.is_object() && last.value("id", 0) == id;
  if (raw_json) {
    std::cout << json{{"jog", id}, {"position", status.at("position")}, {"ended", mine ? last : json(nullptr)}}.dump(1) << "\n";
  } else {
    std::printf("position %s\n", position_text(status.at("position")).c_str());
    if (mine) std::printf("jog %d   %s\n", id, last.value("reason", "").c_str());
    if (!status.value("fault", json(nullptr)).is_null())
      std::printf("fault    %s: %s\n", status["fault"]["kind"].get<std::string>().c_str(),
                  status["fault"]["message"].get<std::string>().c_str());
  }
  return mine && !last.value("fault", json(nullptr)).is_null() ? 1 : 0;
}

// The machine's position as corner `corner` of a measure_plate file, written atomically.
void teach(RpcClient& client, int corner, const std::string& file, bool raw_json) {
  const json status = client.call("machine.status");
  if (!status.value("homed", false)) throw std::runtime_error("the machine is not homed: its position means nothing yet");
  if (!status.value("jog", json(nullptr)).is_null() || status.value("moving", false))
    throw std::runtime_error("the machine is moving: teach once it stands still");
  const json& p = status.at("position");
  const Eigen::Vector3d machine(p.at(0).get<double>(), p.at(1).get<double>(), p.at(2).get<double>());
  json contents = nullptr;
  if (std::filesystem::exists(file)) contents = read_json_file(file);
  TaughtCorner taught;
  try {
    taught = with_taught_corner(contents, corner, machine);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(file + ": " + e.what());
  }
  geometry::write_atomically(file, taught.file.dump(1) + "\n");
  if (raw_json) {
    std::cout << json{{"file", file}, {"id", corner}, {"machine", p}, {"replaced", taught.replaced}}.dump(1) << "\n";
    return;
  }
  std::printf("%s: corner %d rough machine position %s%s\n", file.c_str(), corner, position_text(p).c_str(),
              taught.replaced.is_array() ? std::string(" (was ").append(position_text(taught.replaced)).append(")").c_str() : "");
  std::printf("%s\n", taught.summary.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cmmctl: operate cmmd (docs/api.md). Endpoint: --endpoint, $CMMD_ENDPOINT, "
               "unix:/run/cmmd/cmmd.sock if present, else tcp://127.0.0.1:7620"};
  app.require_subcommand(1);
  app.fallthrough();  // the global options (--station, --broker, --token, …) also after the command
  Global g;
  app.add_option("-e,--endpoint", g.endpoint, "tcp://HOST:PORT or unix:/PATH");
  app.add_option("--token", g.token, "access token for TCP and the broker (or $CMMD_TOKEN)");
  app.add_option("--token-file", g.token_file,
                 "read the token from this file (or $CMMD_TOKEN_FILE; for TCP to this host, /var/lib/cmmd/operator.token "
                 "when readable)");
  app.add_flag("--json", g.raw_json, "print replies as JSON");
  app.add_option("--station", g.station, "send the command to this station through the broker (or $CMMD_STATION)");
  app.add_option("--broker", g.broker, "the fleet's MQTT broker, HOST[:PORT] (or $CMMD_BROKER)");
  app.add_option("--broker-user", g.broker_user, "broker user name (or $CMMD_BROKER_USER)");
  app.add_option("--broker-password", g.broker_password, "broker password (or $CMMD_BROKER_PASSWORD)");
  app.add_option("--broker-ca", g.broker_tls.ca_file, "the broker's CA (PEM): TLS on");
  app.add_option("--broker-cert", g.broker_tls.cert_file, "client certificate (PEM) for the broker");
  app.add_option("--broker-key", g.broker_tls.key_file, "its key (PEM)");
  app.add_option("--topic-prefix", g.topic_prefix, "the fleet's topic prefix (cmmd.json mqtt.topic_prefix)");

  std::string model, corners, measure, name, format = "json", output, tip;
  double scale = 1, delta = 0.2, spacing = 2, angle = 30;
  ScanFlags scan;
  std::uint64_t seed = 1;
  bool watch_job = false, reregister = false, requalify = false, allow_unqualified_tip = false;
  bool units_checked = false;  // sent as "units_checked" (job_request reads the flag's count)
  std::string job_tip = "auto";
  int id = 0;

  auto add_job_options = [&](CLI::App* c) {
    c->add_option("MODEL", model,
                  "mesh (.stl .ply .obj .off) or raw scan (.ply of points, .xyz, .asc, .pcd) to upload, or file:NAME "
                  "from cmmd's models folder")
        ->required();
    c->add_option("--scale", scale, "model units to mm (given, it is taken as checked: no unit check)");
    c->add_flag("--units-checked", units_checked,
                "the model's unit is right even if it looks wrong against the plate (a tiny part)");
    c->add_option("--tolerance", scan.tolerance_mm, "raw scan: largest distance of the mesh from the scanned surface, mm")
        ->check(CLI::PositiveNumber);
    c->add_option("--bin-size", scan.bin_size_mm, "raw scan: thinning bin size, mm, instead of the one --tolerance gives")
        ->check(CLI::PositiveNumber);
    c->add_flag("--adaptive", scan.adaptive, "raw scan: bins follow the curvature (fewer points at the same tolerance)");
    c->add_option("--delta", delta, "bound on a reference point's error, mm (default: cmmd.json)");
    c->add_option("--spacing", spacing, "reference points every this many mm (default: cmmd.json)");
    c->add_option("--feature-angle", angle, "sharp-edge threshold, degrees (default: cmmd.json)");
    c->add_option("--seed", seed, "job seed, recorded in the result");
    c->add_option("--name", name, "free text");
    auto* given = c->add_option("--corners", corners, "corners.json: scan and machine corners (docs/registration.md)");
    c->add_option("--measure-plate", measure, "JSON {scan_corners, rough_machine}: the machine measures the plate")
        ->excludes(given);
  };
  CLI::App* submit = app.add_subcommand("submit", "upload a model and queue a job");
  add_job_options(submit);
  submit->add_flag("-w,--watch", watch_job, "follow the job with a progress bar until it ends");
  submit->add_flag("--requalify", requalify, "qualify a tip by itself when it is not qualified or loses its qualification");
  submit->add_option("--tip", job_tip, "the tip to measure with, or auto: cmmd chooses per feature among the qualified tips");
  submit->add_flag("--allow-unqualified-tip", allow_unqualified_tip,
                   "measure with a tip's nominal radius and offset when it is not qualified (every figure says so)");
  std::string nominal, tolerances_file;
  bool fit_nominal = false;
  double profile_tol = 0, position_tol = 0;
  std::vector<double> diameter_tol;
  submit->add_option("--nominal", nominal, "the part's nominal model (a CAD mesh, in the scan's frame unless --fit-nominal): "
                                           "verdicts against the tolerances");
  submit->add_flag("--fit-nominal", fit_nominal, "best-fit the nominal onto the scan (point-to-plane ICP)");
  submit->add_option("--tolerances", tolerances_file, "JSON file of tolerances (docs/api.md); the flags below override it");
  submit->add_option("--profile-tol", profile_tol, "edge profile tolerance, ± mm")->check(CLI::NonNegativeNumber);
  submit->add_option("--hole-diameter-tol", diameter_tol, "hole diameter tolerance: LOWER UPPER, mm")->expected(2);
  submit->add_option("--hole-position-tol", position_tol, "hole position tolerance (zone diameter), mm")->check(CLI::NonNegativeNumber);
  std::string inspect_file;
  bool exclude_not_probeable = false;
  submit->add_option("--inspect", inspect_file, "JSON file of what to inspect and what to leave out (docs/api.md, Inspect)");
  submit->add_flag("--exclude-not-probeable", exclude_not_probeable,
                   "leave out of the verdict, counted as excluded with the plan's reason, the features the plan finds "
                   "no way to probe in this set-up (e.g. edges standing on the plate)");
  CLI::App* report = app.add_subcommand("report", "a finished job's HTML report");
  report->add_option("ID", id)->required();
  report->add_option("-o,--output", output, "write to this file (default: report-ID.html)");
  CLI::App* preview = app.add_subcommand("preview", "plan a job and dry-run it on a simulator of the reference mesh");
  add_job_options(preview);
  app.add_subcommand("status", "the machine and the running job");
  app.add_subcommand("jobs", "every job, oldest first");
  CLI::App* result = app.add_subcommand("result", "a finished job's result");
  result->add_option("ID", id)->required();
  result->add_option("-f,--format", format, "json, csv or qif")->check(CLI::IsMember({"json", "csv", "qif"}));
  result->add_option("-o,--output", output, "write to this file instead of stdout");
  CLI::App* watch_cmd = app.add_subcommand("watch", "follow a job until it ends");
  watch_cmd->add_option("ID", id)->required();
  for (const char* verb : {"pause", "cancel"}) app.add_subcommand(verb, std::string(verb) + " a job")->add_option("ID", id)->required();
  CLI::App* resume = app.add_subcommand("resume", "continue a paused or interrupted job");
  resume->add_option("ID", id)->required();
  resume->add_flag("--reregister", reregister, "measure the plate again instead of keeping T_M_S");
  app.add_subcommand("home", "home the machine");
  app.add_subcommand("stop", "controlled stop of the machine (a running job pauses)");
  app.add_subcommand("reset", "clear a latched abort or a released e-stop");
  CLI::App* qualify = app.add_subcommand("qualify", "qualify a tip on the reference sphere");
  qualify->add_option("--tip", tip, "tip id (default: the active one)");
  std::vector<double> jog_step;
  double jog_distance = 0, jog_speed = 0;
  CLI::App* jog = app.add_subcommand("jog", "move the machine by hand: a guarded step along DX DY DZ (its length in mm, "
                                            "or --distance), stopped by any contact; Ctrl-C stops it");
  jog->add_option("STEP", jog_step, "DX DY DZ")->required()->expected(3);
  jog->add_option("--distance", jog_distance, "mm along the step's direction (default: the step's length)")->check(CLI::PositiveNumber);
  jog->add_option("--speed", jog_speed, "mm/s (default and limit: cmmd.json jog.max_speed_mm_s)")->check(CLI::PositiveNumber);
  app.add_subcommand("jog-stop", "stop a jog at once");
  int corner = 0;
  std::string corners_file;
  CLI::App* teach_cmd = app.add_subcommand("teach", "take the machine's position as a plate corner's rough position "
                                                    "(measure_plate: rough_machine)");
  teach_cmd->add_option("CORNER_ID", corner, "the plate corner (1, 2, …)")->required();
  teach_cmd->add_option("--file", corners_file, "the measure_plate file (created if missing; the rest kept)")->required();
  app.add_subcommand("ports", "serial ports on this computer, with USB ids");
  app.add_subcommand("fleet", "every station on the broker (--broker) with its state and current job");
  app.add_subcommand("dashboard", "the dashboard's URL to open in a browser (with the operator's token when cmmd.json sets none)");
  app.add_subcommand("rotate-token",
                     "replace the station's operator token (a leaked URL or file): the old one is refused from now on");
  CLI11_PARSE(app, argc, argv);

  const std::string command = app.get_subcommands().front()->get_name();
  try {
    if (command == "ports") {
      const auto ports = hal::list_serial_ports();
      if (ports.empty()) std::printf("no serial ports found\n");
      for (const auto& p : ports) std::printf("%s\n", hal::describe(p).c_str());
      return 0;
    }
    if (command == "fleet") {
      print_fleet(list_fleet(broker_of(g), g.topic_prefix), g.raw_json);
      return 0;
    }
    RpcClient client = connect(g);
    auto show = [&](const json& reply) {
      if (g.raw_json) std::cout << reply.dump(1) << "\n";
      else if (reply.contains("id") && reply.contains("state")) print_record(reply);
      else std::cout << reply.dump(1) << "\n";
    };
    if (command == "submit" || command == "preview") {
      std::string ref = model;
      if (model.rfind("file:", 0) != 0) {
        const bool tty = isatty(STDERR_FILENO) != 0;
        ref = upload_model(client, model, 1u << 20, [&](std::uint64_t sent, std::uint64_t size) {
          if (tty) std::fprintf(stderr, "\rupload %s: %llu of %llu bytes", model.c_str(),
                                static_cast<unsigned long long>(sent), static_cast<unsigned long long>(size));
        });
        if (tty) std::fprintf(stderr, "\n");
      }
      CLI::App* c = command == "submit" ? submit : preview;
      const json request = job_request(ref, *c, scale, delta, spacing, angle, scan, seed, name, corners, measure);
      if (command == "preview") {
        const json preview = client.call("plan.preview", request, 600);
        if (g.raw_json) show(preview);
        else print_preview_summary(model, preview);
        return 0;
      }
      json submitted = request;
      if (requalify) submitted["requalify"] = true;
      if (job_tip != "auto") submitted["tip"] = job_tip;
      if (allow_unqualified_tip) submitted["allow_unqualified_tip"] = true;
      if (!nominal.empty()) {
        std::string nominal_ref = nominal;
        if (nominal.rfind("file:", 0) != 0) nominal_ref = upload_model(client, nominal, 1u << 20, {});
        submitted["nominal"] = {{"model", nominal_ref}, {"placement", fit_nominal ? "fit" : "given"}};
      }
      json tolerances = tolerances_file.empty() ? json::object() : read_json_file(tolerances_file);
      if (submit->count("--profile-tol")) tolerances["edge_profile_mm"] = profile_tol;
      if (submit->count("--hole-diameter-tol")) tolerances["hole_diameter_mm"] = diameter_tol;
      if (submit->count("--hole-position-tol")) tolerances["hole_position_mm"] = position_tol;
      if (!tolerances.empty()) submitted["tolerances"] = tolerances;
      json inspect = inspect_file.empty() ? json::object() : read_json_file(inspect_file);
      if (exclude_not_probeable && inspect.is_object()) inspect["exclude"]["not_probeable"] = true;  // else cmmd says what is wrong
      if (!inspect.empty()) submitted["inspect"] = inspect;
      const json record = client.call("job.submit", submitted, 120);
      id = record.at("id").get<int>();
      std::printf("job %d queued (%s)\n", id, ref.c_str());
      std::fflush(stdout);  // before the progress on stderr
      if (!watch_job) return 0;
      const int code = watch(client, id);
      if (code == 0 && !g.raw_json) print_result_summary(client.call("job.result", {{"job", id}}, 120));
      return code;
    }
    if (command == "watch") return watch(client, id);
    if (command == "status") {
      const json s = client.call("machine.status");
      if (g.raw_json) {
        std::cout << s.dump(1) << "\n";
        return 0;
      }
      const bool up = s.value("link", "?") == "up";
      std::printf("machine  %s, link %s, %s, %s\n", s.value("driver", "?").c_str(), s.value("link", "?").c_str(),
                  s.value("lifecycle", "?").c_str(), !up ? "homed unknown" : s.value("homed", false) ? "homed" : "not homed");
      // A pressed e-stop cannot be read over a link that is down: unknown, never "released".
      if (const json estop = s.value("estop", json(nullptr)); estop.is_boolean())
        std::printf("e-stop   %s\n", estop.get<bool>() ? "PRESSED" : "released");
      else
        std::printf("e-stop   unknown%s\n", up ? "" : " (the link is down)");
      const json why_down = s.value("connect_error", json(nullptr));
      if (why_down.is_object())
        std::printf("connect  failed %s: %s\n", why_down.value("utc", "?").c_str(),
                    fault_text(why_down.value("kind", "?"), why_down.value("message", "")).c_str());
      if (s.contains("position") && s["position"].is_array())
        std::printf("position (%.4f, %.4f, %.4f) tip %s\n", s["position"][0].get<double>(), s["position"][1].get<double>(),
                    s["position"][2].get<double>(), s.value("tip", "").c_str());
      for (const json& t : s.value("tips", json::array())) {
        const json q = t.value("qualification", json(nullptr));
        std::printf("tip      %s%s r %.4f mm, %s\n", t.value("id", "?").c_str(), t.value("active", false) ? " (active)" : "",
                    t.value("ball_radius_mm", 0.0),
                    q.is_object() ? ("qualified " + q.value("time_utc", std::string("?"))).c_str()
                                  : "NOT QUALIFIED (nominal radius and offset)");
      }
      if (const json jog = s.value("jog", json(nullptr)); jog.is_object())
        std::printf("jog      %d along %s at %g mm/s\n", jog.value("id", 0), position_text(jog.at("direction")).c_str(),
                    jog.value("speed_mm_s", 0.0));
      // While the link is down the fault is the connect error, already printed.
      if (const json fault = s.value("fault", json(nullptr));
          fault.is_object() && !(why_down.is_object() && fault.value("message", "") == why_down.value("message", "")))
        std::printf("fault    %s\n", fault_text(fault.value("kind", "?"), fault.value("message", "")).c_str());
      if (!s.value("job", json(nullptr)).is_null()) print_record(client.call("job.get", {{"job", s["job"]}}));
      return 0;
    }
    if (command == "jobs") {
      const json jobs = client.call("job.list").at("jobs");
      if (g.raw_json) std::cout << jobs.dump(1) << "\n";
      else if (jobs.empty()) std::printf("no jobs\n");
      for (const json& r : jobs)
        if (!g.raw_json) print_record(r);
      return 0;
    }
    if (command == "report") {
      const json r = client.call("job.report", {{"job", id}}, 120);
      const std::string file = output.empty() ? "report-" + std::to_string(id) + ".html" : output;
      geometry::write_atomically(file, r.at("html").get<std::string>());
      std::printf("%s: the report of job %d\n", file.c_str(), id);
      return 0;
    }
    if (command == "result") {
      const json r = client.call("job.result", {{"job", id}, {"format", format}}, 120);
      const std::string text = format == "json" ? r.dump(1) + "\n" : r.at(format).get<std::string>();
      if (output.empty() && format == "json" && !g.raw_json) {
        print_result_summary(r);  // an operator at a terminal; --json or -o for the whole JSON
      } else if (output.empty()) {
        std::cout << text;
      } else {
        std::ofstream out(output);
        out << text;
        if (!out.flush()) throw std::runtime_error(output + ": cannot be written");
      }
      return 0;
    }
    if (command == "pause" || command == "cancel") show(client.call("job." + command, {{"job", id}}));
    else if (command == "resume") show(client.call("job.resume", {{"job", id}, {"reregister", reregister}}));
    else if (command == "home") show(client.call("machine.home", json::object(), 600));
    else if (command == "dashboard") {
      const json d = client.call("server.dashboard");
      if (g.raw_json) std::cout << d.dump(1) << "\n";
      else std::printf("%s\n", d.at("url").get<std::string>().c_str());
    }
    else if (command == "rotate-token") {
      client.call("server.rotate_token");
      std::printf("the station's operator token was replaced: the old one is refused from now on\n");
      try {
        const json d = client.call("server.dashboard");  // the URL carries the new token
        std::printf("the dashboard's URL is now %s\n", d.at("url").get<std::string>().c_str());
      } catch (const RpcError&) {
        // No dashboard (http.enabled false): the token is in the state folder's operator.token.
      }
    }
    else if (command == "stop" || command == "reset") show(client.call("machine." + command));
    else if (command == "jog-stop") show(client.call("machine.jog_stop"));
    else if (command == "teach") teach(client, corner, corners_file, g.raw_json);
    else if (command == "jog") {
      const Eigen::Vector3d step(jog_step[0], jog_step[1], jog_step[2]);
      if (step.norm() == 0) throw std::runtime_error("DX DY DZ must not all be zero");
      const double distance = jog->count("--distance") ? jog_distance : step.norm();
      json params = {{"direction", {step.x(), step.y(), step.z()}}, {"distance_mm", distance}};
      if (jog->count("--speed")) params["speed_mm_s"] = jog_speed;
      return step_jog(client, params, distance, g.raw_json);
    }
    else if (command == "qualify") {
      json params = json::object();
      if (!tip.empty()) params["tip"] = tip;
      const json q = client.call("machine.qualify", params, 600);
      if (g.raw_json) std::cout << q.dump(1) << "\n";
      else
        std::printf("tip %s qualified: ball radius %.5f mm, offset (%s, %s, %s) mm, sphere fit RMS %.5f mm, %s\n",
                    q["tip"].get<std::string>().c_str(), q["ball_radius_mm"].get<double>(),
                    fmt("%.5f", q["offset"][0].get<double>()).c_str(), fmt("%.5f", q["offset"][1].get<double>()).c_str(),
                    fmt("%.5f", q["offset"][2].get<double>()).c_str(), q["residual_rms_mm"].get<double>(),
                    q["time_utc"].get<std::string>().c_str());
    }
    return 0;
  } catch (const RpcError& e) {
    std::fprintf(stderr, "cmmctl %s: cmmd refused (%d): %s\n", command.c_str(), e.code(), e.what());
    if (!e.data().is_null()) std::fprintf(stderr, "  %s\n", e.data().dump().c_str());
    return 1;
  } catch (const RpcClientError& e) {
    std::fprintf(stderr, "cmmctl %s: %s\n", command.c_str(), e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cmmctl %s: %s\n", command.c_str(), e.what());
    return 1;
  }
}
