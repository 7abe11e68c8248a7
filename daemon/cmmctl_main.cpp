// cmmctl: the operator's command line for cmmd — submit a model and watch the job, query and steer
// jobs and the machine, list serial ports. Talks JSON-RPC over the Unix socket or TCP.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>

#include "daemon/client/model_upload.hpp"
#include "daemon/client/progress_bar.hpp"
#include "daemon/client/rpc_client.hpp"
#include "daemon/client/rpc_error.hpp"
#include "hal/serial_ports.hpp"

namespace {

using namespace cmm;
using namespace cmm::daemon;
using nlohmann::json;

struct Global {
  std::string endpoint;
  std::string token;
  bool raw_json = false;
};

std::string default_endpoint() {
  if (const char* e = std::getenv("CMMD_ENDPOINT"); e != nullptr && *e != '\0') return e;
  if (std::filesystem::exists("/run/cmmd/cmmd.sock")) return "unix:/run/cmmd/cmmd.sock";
  return "tcp://127.0.0.1:7620";
}

RpcClient connect(const Global& g) {
  RpcClient client = RpcClient::connect(g.endpoint.empty() ? default_endpoint() : g.endpoint);
  std::string token = g.token;
  if (token.empty())
    if (const char* t = std::getenv("CMMD_TOKEN")) token = t;
  if (!token.empty()) client.call("server.auth", {{"token", token}});
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

// How a raw scan is meshed (docs/api.md, Job request): sent only when given, so cmmd's defaults hold.
struct ScanFlags {
  double tolerance_mm = 0.05;
  double bin_size_mm = 0;
  bool adaptive = false;
};

json job_request(const std::string& model, const CLI::App& submit, double scale, double delta, double spacing,
                 double angle, const ScanFlags& scan, std::uint64_t seed, const std::string& name,
                 const std::string& corners, const std::string& measure) {
  json r = {{"model", model}, {"scale", scale}, {"seed", seed}};
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cmmctl: operate cmmd (docs/api.md). Endpoint: --endpoint, $CMMD_ENDPOINT, "
               "unix:/run/cmmd/cmmd.sock if present, else tcp://127.0.0.1:7620"};
  app.require_subcommand(1);
  Global g;
  app.add_option("-e,--endpoint", g.endpoint, "tcp://HOST:PORT or unix:/PATH");
  app.add_option("--token", g.token, "access token for TCP (or $CMMD_TOKEN)");
  app.add_flag("--json", g.raw_json, "print replies as JSON");

  std::string model, corners, measure, name, format = "json", output, tip;
  double scale = 1, delta = 0.2, spacing = 2, angle = 30;
  ScanFlags scan;
  std::uint64_t seed = 1;
  bool watch_job = false, reregister = false, requalify = false;
  int id = 0;

  auto add_job_options = [&](CLI::App* c) {
    c->add_option("MODEL", model,
                  "mesh (.stl .ply .obj .off) or raw scan (.ply of points, .xyz, .asc, .pcd) to upload, or file:NAME "
                  "from cmmd's models folder")
        ->required();
    c->add_option("--scale", scale, "model units to mm");
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
  submit->add_flag("--requalify", requalify, "qualify the tip again by itself if the machine loses its qualification");
  CLI::App* preview = app.add_subcommand("preview", "plan a job and dry-run it on a simulator of the reference mesh");
  add_job_options(preview);
  app.add_subcommand("status", "the machine and the running job");
  app.add_subcommand("jobs", "every job, oldest first");
  CLI::App* result = app.add_subcommand("result", "a finished job's result");
  result->add_option("ID", id)->required();
  result->add_option("-f,--format", format, "json or csv")->check(CLI::IsMember({"json", "csv"}));
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
  app.add_subcommand("ports", "serial ports on this computer, with USB ids");
  CLI11_PARSE(app, argc, argv);

  const std::string command = app.get_subcommands().front()->get_name();
  try {
    if (command == "ports") {
      const auto ports = hal::list_serial_ports();
      if (ports.empty()) std::printf("no serial ports found\n");
      for (const auto& p : ports) std::printf("%s\n", hal::describe(p).c_str());
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
        show(client.call("plan.preview", request, 600));
        return 0;
      }
      json submitted = request;
      if (requalify) submitted["requalify"] = true;
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
      std::printf("machine  %s, link %s, %s, %s\n", s.value("driver", "?").c_str(), s.value("link", "?").c_str(),
                  s.value("lifecycle", "?").c_str(), s.value("homed", false) ? "homed" : "not homed");
      if (s.contains("position") && s["position"].is_array())
        std::printf("position (%.4f, %.4f, %.4f) tip %s\n", s["position"][0].get<double>(), s["position"][1].get<double>(),
                    s["position"][2].get<double>(), s.value("tip", "").c_str());
      if (!s.value("fault", json(nullptr)).is_null())
        std::printf("fault    %s: %s\n", s["fault"]["kind"].get<std::string>().c_str(), s["fault"]["message"].get<std::string>().c_str());
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
    if (command == "result") {
      const json r = client.call("job.result", {{"job", id}, {"format", format}}, 120);
      const std::string text = format == "csv" ? r.at("csv").get<std::string>() : r.dump(1) + "\n";
      if (output.empty()) {
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
    else if (command == "stop" || command == "reset") show(client.call("machine." + command));
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
